"""The operator console in a real browser (Debian's Chromium, headless, driven by selenium) against the real
mode manager and the real sim, judged on the sim's record.

One stack, one console and one browser for the file; the tests run in file order, each leaving the robot as the
next expects (walking on W, then stopped, then driven by a planner handed the robot on the page and taken back,
then standing under a policy engaged from the Policy card and handed back, then damped on the floor and got up by
the Recover button, then e-stopped during a second recovery, whose incident file the Last incident card then shows).
The node runs with the policy tests' steady bounds (STEADY_POLICY), which change nothing outside LOW_LEVEL, and writes
its incidents into a folder of the test's, which the console is given too. Set G1_CONSOLE_SCREENSHOTS=<folder> to
also save the page while driving, while a planner drives and in EMERGENCY, the Policy card while the policy drives
and the Last incident card after the e-stop (the pictures: ``console_driving.png``, ``console_autonomy.png``,
``console_emergency.png``, ``console_policy.png``, ``console_incident.png``).
"""

from __future__ import annotations

import json
import os
import signal
import time
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path

import pytest
from geometry_msgs.msg import Twist

from e2e.test_policy import STEADY_POLICY
from e2e.user_ctrl_session import (
    STANDING_Z_M,
    enter_walking,
    fsm_states,
    internal_ctrl,
    lowest_pelvis,
    no_user_frame_before_1000,
    wait_at_rest,
)
from g1_mode_manager.core.recorder.incidents import Cause, list_incidents
from g1_mode_manager.node.settings import Settings
from g1_mode_manager.protocol import api_ids
from g1_mode_manager.protocol.fsm import STANDING_FSM_IDS, BalanceMode, FsmId, FsmMode, InternalCtrl
from support.console import (
    Console,
    RawPage,
    Twists,
    browser_missing,
    chromium,
    http_get,
    set_window_state,
    start_console,
)
from support.holosoma import POLICY_KP_MAX, policy_frame
from support.mode_manager import wait_until
from support.planner import start_planner
from support.sim_record import SimRecord, damped, fsm_of, is_damp, requests, states, velocity_of
from support.timing import INCIDENT_AFTER_S, INCIDENT_WRITE_S, QUIET_WINDOW_S, RECORD_WAIT_S

from .conftest import Stack

MISSING = browser_missing()
pytestmark = [pytest.mark.e2e, pytest.mark.sim, pytest.mark.skipif(MISSING is not None, reason=f"no browser: {MISSING}")]

NODE = Settings()  # the mode manager's defaults, which the stack runs with (STEADY_POLICY's aside)
WATCHDOG_S = NODE.cmd_vel_timeout_s
ONE_RPC_S = NODE.rpc_timeout_s
DEADLINE_S = 0.3  # the console's heartbeat_deadline_s
PUBLISH_PERIOD_S = 0.05  # its publish_rate_hz
TOKEN = "operator-token-for-the-test"
W_SPEED = 0.5 * 0.5  # the W key: half of the console's max_vx 0.5 m/s
#: The scripted planner walks forward and turns (within the autonomy's limits); W only walks forward, so on the
#: record a Move that turns is the planner's and one that goes forward without turning is the page's.
PLANNER_VX, PLANNER_WZ = 0.3, 0.3
#: What the recovery's steps send: damp (SetFsmId 1), lie_to_stand (SetFsmId 702), balance_stand (SetBalanceMode 0).
RECOVERY_CALLS = [(api_ids.LOCO_SET_FSM_ID, FsmId.DAMP), (api_ids.LOCO_SET_FSM_ID, FsmId.LIE_TO_STAND),
                  (api_ids.LOCO_SET_BALANCE_MODE, BalanceMode.BALANCE_STAND)]


@dataclass
class Rig:
    stack: Stack
    console: Console
    driver: object
    twists: Twists
    token_file: Path
    shots: Path | None
    incidents: Path  # the node's recorder_dir, given to the console too


@pytest.fixture(scope="module")
def rig(module_stack_factory, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Rig]:
    # measured velocity and tilt for the plots; the policy's loop out of a loaded machine's way; the e-stop's incident
    # in a folder of the test's, written soon after it
    incidents = tmp_path_factory.mktemp("incidents")
    stack = module_stack_factory(node_params=("odom_rate_hz:=20.0", *STEADY_POLICY, f"recorder_dir:={incidents}",
                                              f"recorder_after_s:={INCIDENT_AFTER_S}"))
    twists = Twists()
    stack.ros.node.create_subscription(Twist, "/cmd_vel", twists, 100)  # what the console publishes, when
    token_file = tmp_path_factory.mktemp("console") / "token"
    token_file.write_text(TOKEN + "\n")
    shots = os.environ.get("G1_CONSOLE_SCREENSHOTS")
    console = start_console(f"recorder_dir:={incidents}")
    try:
        with chromium() as driver:
            r = Rig(stack, console, driver, twists, token_file, Path(shots) if shots else None, incidents)
            yield r
            console = r.console
    finally:
        code = console.proc.stop()
        assert code in (0, -signal.SIGKILL), console.proc.output()[-3000:]


def _text(driver, element_id: str) -> str:
    from selenium.webdriver.common.by import By

    return driver.find_element(By.ID, element_id).text


def _click(driver, selector: str) -> float:
    """Click; returns the time just before (what the click sets off can reach the robot before click() returns)."""
    from selenium.webdriver.common.by import By

    element = driver.find_element(By.CSS_SELECTOR, selector)
    before = time.monotonic()
    element.click()
    return before


def _keys(driver, *, down: str = "", up: str = "") -> float:
    """Press or release keys; returns the time just before."""
    from selenium.webdriver.common.action_chains import ActionChains

    chain = ActionChains(driver)
    if up:
        chain.key_up(up)
    if down:
        chain.key_down(down)
    before = time.monotonic()
    chain.perform()
    return before


def _page_shows(driver, element_id: str, predicate, timeout_s: float = 10.0) -> str:
    assert wait_until(lambda: predicate(_text(driver, element_id)), timeout_s), \
        f"#{element_id} shows {_text(driver, element_id)!r}"
    return _text(driver, element_id)


def _moves(record: SimRecord, since: float, *, stop: bool) -> list[dict]:
    """SetVelocity requests the robot received since ``since``: StopMoves (0, 0, 0) or Moves."""
    return [e for e in record.events(since) if e["k"] == "req" and e.get("api") == api_ids.LOCO_SET_VELOCITY
            and (velocity_of(e) == [0.0, 0.0, 0.0]) == stop]


def _shot(r: Rig, name: str, height: int | None = None, card: str | None = None) -> None:
    """Save the page as it shows now; ``height``: from its top in a window this tall (the plots too); ``card``: only
    the element with this id, scrolled to just below the page's sticky head."""
    if r.shots is None:
        return
    from selenium.webdriver.common.by import By

    r.shots.mkdir(parents=True, exist_ok=True)
    size = r.driver.get_window_size()
    if height is not None:
        r.driver.set_window_size(size["width"], height)
        r.driver.execute_script("window.scrollTo(0, 0)")
        time.sleep(0.5)  # the page draws its plots again on resize
    if card is None:
        r.driver.save_screenshot(str(r.shots / name))
    else:
        r.driver.execute_script("const c = document.getElementById(arguments[0]);"
                                "window.scrollTo(0, c.offsetTop - document.getElementById('head').offsetHeight - 8)",
                                card)
        time.sleep(0.3)
        r.driver.find_element(By.ID, card).screenshot(str(r.shots / name))
    if height is not None:
        r.driver.set_window_size(size["width"], size["height"])


def _watchdog_stopped_the_robot(r: Rig, t_let_go: float, what: str) -> None:
    """Judged on the record: the console's last cmd_vel within its heartbeat deadline of the let-go, then a
    StopMove within the node's watchdog plus one RPC, and no Move after it."""
    time.sleep(WATCHDOG_S + ONE_RPC_S + 0.3)
    before = [t for t, *_ in r.twists.seen if t <= t_let_go + 1.0]
    last_twist = before[-1]
    # slack for a loaded machine: a page message taken late by the console's event loop counts from then
    assert not r.twists.since(t_let_go + DEADLINE_S + PUBLISH_PERIOD_S + 0.4), f"{what}: cmd_vel went on"
    stops = _moves(r.stack.record, last_twist, stop=True)
    assert stops, f"{what}: no StopMove on the record after the console's last cmd_vel"
    stop_at = stops[0]["t"]
    moves = _moves(r.stack.record, t_let_go - 1.0, stop=False)
    assert moves, f"{what}: the robot was not walking when the page let go"
    last_move = moves[-1]["t"]
    print(f"{what}: last cmd_vel {1000 * (last_twist - t_let_go):+.0f} ms, last Move {1000 * (last_move - t_let_go):+.0f}"
          f" ms, StopMove {1000 * (stop_at - t_let_go):+.0f} ms after the page let go "
          f"(StopMove {1000 * (stop_at - last_twist):.0f} ms after the last cmd_vel)")
    assert stop_at - last_twist <= WATCHDOG_S + ONE_RPC_S, "the StopMove came later than the watchdog + one RPC"
    assert stop_at - t_let_go <= DEADLINE_S + WATCHDOG_S + ONE_RPC_S, "the StopMove came too late after the let-go"
    assert last_move < stop_at, "a Move reached the robot after the StopMove"


def test_the_page_shows_the_mode_sets_high_level_starts_and_drives_on_w(rig: Rig) -> None:
    r, d = rig, rig.driver
    modes = r.stack.modes()
    assert wait_until(lambda: bool(modes), 10.0)
    d.get(r.console.url)
    _page_shows(d, "mode-name", lambda text: text == modes[-1].name)  # what ~/mode says
    assert "connected" in _text(d, "conn")
    t_click = _click(d, 'button[data-mode="high_level"]')
    _page_shows(d, "mode-name", lambda text: text == "HIGH_LEVEL", 20.0)
    assert wait_until(lambda: modes[-1].name == "HIGH_LEVEL", 5.0), modes[-1]  # the test's own ~/mode: another path
    assert "success=true" in _page_shows(d, "mode-answer", lambda text: "success=" in text)
    assert any(e.get("api") == api_ids.MS_CHECK_MODE for e in r.stack.record.events(t_click) if e["k"] == "req")
    assert r.stack.sim.get()["sport"]["mode"] == "ai"  # the sim's service, as the robot reports it
    _click(d, 'button[data-verb="start"]')
    assert "success=true" in _page_shows(d, "loco-answer", lambda text: "success=" in text, 10.0)
    assert r.stack.sim.get()["sport"]["fsm_id"] == 500
    t_w = _keys(d, down="w")
    assert wait_until(lambda: bool(_moves(r.stack.record, t_w, stop=False)), 5.0), "W held: no Move reached the robot"
    _page_shows(d, "teleop-status", lambda text: text.startswith("DRIVING"), 5.0)
    assert all(vx == pytest.approx(W_SPEED) for _, vx, _, _ in r.twists.since(t_w))
    time.sleep(4.0 if r.shots else 0.5)  # a few plot points
    _shot(r, "console_driving.png", height=1500)


def test_a_second_console_is_told_who_drives_and_bad_input_leaves_driving_and_node_alone(rig: Rig) -> None:
    r, d = rig, rig.driver
    me = _text(d, "you").removeprefix("you are ")
    other = RawPage(r.console.ws_url())
    try:
        other.hold(vx=-1.0)  # the other page holds S as hard as it can
        told = other.wait_for(lambda m: m["type"] == "state" and m["teleop"]["why_not"] == f"{me} drives", 5.0)
        assert told["teleop"]["driver"] == me and not told["teleop"]["publishing"] and not told["teleop"]["you_drive"]
        t_bad = time.monotonic()
        for bad in ("{", '{"type": "launch_missiles"}', '{"type": "teleop"}', "x" * 5000, b"\x00"):
            other.send(bad)
        flood = ('{"type": "teleop", "visible": true, "focused": true, "vx": -1, "vy": 0, "wz": 0, "seq": 1}',)
        other.send_many(list(flood) * 1000)  # the other page floods its S
        time.sleep(1.0)
        refused = other.wait_for(lambda m: m["type"] == "state" and m["your_refused"].get("flood", 0) >= 500)
        print(f"the second console's refusals: {refused['your_refused']}")
        assert all(refused["your_refused"].get(k, 0) >= 1 for k in ("malformed", "unknown", "bad_value", "oversized"))
        assert all(vx == pytest.approx(W_SPEED) for _, vx, _, _ in r.twists.since(t_bad)), "the second console drove"
        # Moves go out at 10 Hz; a machine busy with the flood may leave a half-second gap without one
        assert wait_until(lambda: bool(_moves(r.stack.record, time.monotonic() - 0.5, stop=False)), 3.0), "driving stopped"
        assert all(velocity_of(e)[0] > 0 for e in _moves(r.stack.record, t_bad, stop=False))
    finally:
        other.close()
    assert r.stack.node.alive() and r.console.proc.alive()
    assert r.stack.modes()[-1].name == "HIGH_LEVEL"


def test_a_hidden_page_stops_publishing_at_once_and_the_watchdog_stops_the_robot(rig: Rig) -> None:
    r, d = rig, rig.driver
    walking = lambda: bool(_moves(r.stack.record, time.monotonic() - 0.5, stop=False))  # noqa: E731
    assert wait_until(walking, 3.0), "not walking before the page is hidden"
    t_hidden = time.monotonic()
    set_window_state(d, "minimized")  # visibilitychange -> hidden, and a blur: as a phone's screen lock
    hidden = lambda: d.execute_script("return document.visibilityState") == "hidden"  # noqa: E731
    assert wait_until(hidden, 5.0)
    assert "STOPPED" in _page_shows(d, "teleop-status", lambda text: "STOPPED" in text, 2.0)
    _watchdog_stopped_the_robot(r, t_hidden, "page hidden")
    set_window_state(d, "normal")


def test_killing_the_console_while_driving_lets_the_watchdog_stop_the_robot(rig: Rig) -> None:
    r, d = rig, rig.driver
    t_w = _keys(d, up="w", down="w")  # the blur let go of W: press it again
    assert wait_until(lambda: bool(_moves(r.stack.record, t_w, stop=False)), 5.0), "W held again: no Move"
    time.sleep(0.5)
    t_kill = time.monotonic()
    os.killpg(r.console.proc.proc.pid, signal.SIGKILL)  # no goodbye: the process is simply gone
    r.console.proc.proc.wait(5.0)
    _watchdog_stopped_the_robot(r, t_kill, "console killed")
    _page_shows(d, "conn", lambda text: "DISCONNECTED" in text, 5.0)
    assert r.stack.node.alive()
    _keys(d, up="w")
    r.console = start_console(f"token_file:={r.token_file}", f"recorder_dir:={r.incidents}")  # the next: with a token


def _velocities(record: SimRecord, since: float) -> list[tuple[float, list[float]]]:
    """(receive time, [vx, vy, wz]) of every SetVelocity the robot received since ``since``, StopMoves included."""
    return [(e["t"], velocity_of(e)) for e in requests(record.events(since), api_ids.LOCO_SET_VELOCITY)]


def _planner_moves(record: SimRecord, since: float) -> list[tuple[float, list[float]]]:
    return [(t, v) for t, v in _velocities(record, since) if v[2] != 0.0]


def _page_moves(record: SimRecord, since: float) -> list[tuple[float, list[float]]]:
    return [(t, v) for t, v in _velocities(record, since) if v[0] > 0.0 and v[2] == 0.0]


def _answered(driver, what: str) -> str:
    """The Drive card's answer to ``what`` (the click just set it to "sent, waiting"), asserted a success."""
    answer = _page_shows(driver, "drive-answer", lambda text: text.startswith(f"{what} (") and "success=" in text, 10.0)
    assert "success=true" in answer, answer
    return answer


def test_a_planner_drives_once_handed_over_on_the_page_a_hidden_page_leaves_it_and_w_takes_it_back(rig: Rig) -> None:
    r, d = rig, rig.driver
    d.get(r.console.url + f"?token={TOKEN}")  # the console the test before started, with a token
    _page_shows(d, "driver", lambda text: text == "drives: teleop")
    planner = start_planner(f"{r.stack.ns}/cmd_vel_nav", PLANNER_VX, 0.0, PLANNER_WZ)
    try:
        t_hand = _click(d, "#hand-over")
        _answered(d, "hand over to autonomy")
        _page_shows(d, "driver", lambda text: text == "drives: autonomy", 5.0)
        colour = "return getComputedStyle(document.getElementById('mode-name')).color"
        cyan = lambda: d.execute_script(colour) == "rgb(0, 255, 255)"  # noqa: E731
        assert wait_until(cyan, 5.0), d.execute_script(colour)  # the head LED's look while the autonomy drives
        assert wait_until(lambda: len(_planner_moves(r.stack.record, t_hand)) >= 5, RECORD_WAIT_S), \
            (_text(d, "driver"), _velocities(r.stack.record, t_hand)[:5], r.stack.node.output()[-3000:])
        assert all(v[0] > 0.0 and v[2] > 0.0 for _, v in _planner_moves(r.stack.record, t_hand))

        # the page hidden: its dead-man lets go of what it sends (nothing), the planner drives on
        t_hidden = time.monotonic()
        set_window_state(d, "minimized")
        time.sleep(QUIET_WINDOW_S)
        hidden = _velocities(r.stack.record, t_hidden)
        assert len(hidden) >= 5 and all(v[2] > 0.0 for _, v in hidden), f"the planner stopped: {hidden}"
        set_window_state(d, "normal")
        # its command in the velocity plot (from /diagnostics, 1 Hz), beside the measured speed
        plotted = "return history.map((s) => s.auto).filter((v) => v !== null && v !== undefined)"
        assert wait_until(lambda: any(abs(v - PLANNER_VX) < 1e-3 for v in d.execute_script(plotted)), 5.0), \
            d.execute_script(plotted)
        time.sleep(3.0 if r.shots else 0.0)  # a few plot points
        _shot(r, "console_autonomy.png", height=1500)

        # W held: the human's takeover (a non-zero cmd_vel); no planner Move after the page's first
        t_w = _keys(d, down="w")
        assert wait_until(lambda: bool(_page_moves(r.stack.record, t_w)), RECORD_WAIT_S), "W: no Move of the page"
        _page_shows(d, "driver", lambda text: text == "drives: teleop", 5.0)
        time.sleep(0.5)
        t_up = _keys(d, up="w")
        first_page = _page_moves(r.stack.record, t_w)[0][0]
        late = [(t, v) for t, v in _planner_moves(r.stack.record, first_page) if t < t_up]
        assert not late, f"planner Moves after the page's first Move: {late[:5]}"
        last_planner = max(t for t, _ in _planner_moves(r.stack.record, t_hand) if t < first_page)
        print(f"W pressed -> last planner Move {1000 * (last_planner - t_w):+.0f} ms, the page's first Move "
              f"{1000 * (first_page - t_w):+.0f} ms (the robot's record)")

        # handed over again once the page's W has stopped (a cmd_vel of W still on its way would take over again,
        # as the human's command should), then TAKE OVER: a StopMove, and no planner Move after it
        at_rest = lambda: any(v == [0.0, 0.0, 0.0] for _, v in _velocities(r.stack.record, t_up))  # noqa: E731
        assert wait_until(at_rest, RECORD_WAIT_S), "W released: no StopMove"
        t_again = _click(d, "#hand-over")
        _answered(d, "hand over to autonomy")
        assert wait_until(lambda: len(_planner_moves(r.stack.record, t_again)) >= 3, RECORD_WAIT_S), \
            (_text(d, "driver"), _velocities(r.stack.record, t_again)[:5], r.stack.node.output()[-3000:])
        t_take = _click(d, "#take-over")
        _answered(d, "take over")
        _page_shows(d, "driver", lambda text: text == "drives: teleop", 5.0)
        stopped = lambda: next((t for t, v in _velocities(r.stack.record, t_take) if v == [0.0, 0.0, 0.0]), None)  # noqa: E731
        assert wait_until(lambda: stopped() is not None, RECORD_WAIT_S), "TAKE OVER: no StopMove"
        time.sleep(0.5)
        assert _planner_moves(r.stack.record, stopped()) == [], "a planner Move after TAKE OVER's StopMove"
        print(f"TAKE OVER clicked -> StopMove {1000 * (stopped() - t_take):.0f} ms")
    finally:
        planner.stop()


def _policy_answered(driver, what: str) -> str:
    """The Policy card's answer to ``what`` (the click just set it to "sent, waiting"), asserted a success."""
    answer = _page_shows(driver, "policy-answer", lambda text: text.startswith(f"{what} (") and "success=" in text,
                         RECORD_WAIT_S)
    assert "success=true" in answer, answer
    return answer


def _policy_verb(driver, verb: str) -> float:
    """Click the Policy card's ``verb``; returns the time just before."""
    return _click(driver, f'button[data-policy-verb="{verb}"]')


def _policy_frames(record: SimRecord, since: float) -> list[dict]:
    """The policy's frames the robot applied on rt/user_lowcmd since ``since`` (its stiffness tells them apart)."""
    return [e for e in record.events(since) if policy_frame(e) and e["topic"] == "user_lowcmd" and e["ok"]]


#: What the page plots (policy.js): the largest |target - measured| of each state, and the joints behind the bars.
PLOTTED_ERRORS = "return policyCard.history.map((s) => s.err).filter((v) => v !== null && v !== undefined)"
PLOTTED_JOINTS = "return lastState && lastState.policy ? lastState.policy.joints : null"


def test_a_policy_loaded_shadowed_and_engaged_on_the_page_drives_the_robot_and_disengage_leaves_it_standing(
        rig: Rig) -> None:
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import Select

    r, d = rig, rig.driver
    d.get(r.console.url + f"?token={TOKEN}")  # the console the test before the planner's started, with a token
    _page_shows(d, "policy-phase", lambda text: text == "UNLOADED")
    modes = r.stack.modes()
    assert wait_until(lambda: bool(modes), RECORD_WAIT_S)
    if modes[-1].name == "HIGH_LEVEL":  # where the planner's test left it: walked, stopped by TAKE OVER
        wait_at_rest(r.stack)
    else:  # this test on its own
        enter_walking(r.stack)
    _page_shows(d, "mode-name", lambda text: text == "HIGH_LEVEL")

    Select(d.find_element(By.ID, "policy-name")).select_by_value("loco_ppo")
    _policy_verb(d, "load")
    print(_policy_answered(d, "policy load loco_ppo"))
    _page_shows(d, "policy-phase", lambda text: text == "LOADED")
    assert _text(d, "policy-loaded") == "loco_ppo" and r.stack.sim.get()["sport"]["fsm_id"] != 1000
    _policy_verb(d, "shadow")
    _policy_answered(d, "policy shadow")
    _page_shows(d, "policy-phase", lambda text: text == "SHADOW")
    _page_shows(d, "policy-rate", lambda text: text.endswith(" Hz"))
    # the targets against the measured joints, plotted: the largest difference over time and every joint now
    assert wait_until(lambda: len(d.execute_script(PLOTTED_ERRORS)) >= 3, RECORD_WAIT_S), d.execute_script(PLOTTED_ERRORS)
    joints = d.execute_script(PLOTTED_JOINTS)
    assert joints and len(joints["target"]) == len(joints["measured"]) == 29, joints
    bound = d.execute_script("return lastState.policy.engage_limit_rad")
    assert bound == NODE.policy_engage_max_error_rad
    assert not _policy_frames(r.stack.record, 0.0), "the shadow sent a frame"
    # ENGAGE once the page shows every joint's target within the node's bound, as an operator would wait for it
    assert wait_until(lambda: d.execute_script(PLOTTED_ERRORS)[-1] < bound, RECORD_WAIT_S), \
        d.execute_script(PLOTTED_ERRORS)[-5:]

    t_engage = _policy_verb(d, "engage")
    print(_policy_answered(d, "policy engage"))
    print(f"the page: {_page_shows(d, 'policy-phase', lambda text: text in ('BLENDING', 'RUNNING'))}")
    _page_shows(d, "policy-phase", lambda text: text == "RUNNING", RECORD_WAIT_S)
    _page_shows(d, "mode-name", lambda text: text == "LOW_LEVEL")
    assert wait_until(lambda: bool(_policy_frames(r.stack.record, t_engage)), RECORD_WAIT_S), "no policy frame"
    no_user_frame_before_1000(r.stack.record.events(t_engage), user_kp=POLICY_KP_MAX)
    time.sleep(3.0 if r.shots else 0.0)  # a few plot points under the policy
    _shot(r, "console_policy.png", height=1500, card="policy-card")

    t_disengage = _policy_verb(d, "disengage")
    print(_policy_answered(d, "policy disengage"))
    _page_shows(d, "policy-phase", lambda text: text == "LOADED", RECORD_WAIT_S)
    _page_shows(d, "mode-name", lambda text: text == "HIGH_LEVEL")
    standing = lambda: fsm_states(r.stack.record.events(t_disengage))[-1][1] in STANDING_FSM_IDS  # noqa: E731
    assert wait_until(standing, RECORD_WAIT_S), fsm_states(r.stack.record.events(t_disengage))[-3:]
    assert internal_ctrl(r.stack.record.events(t_disengage)) == [InternalCtrl.WALKRUN]
    # the policy's frames have ended: none more on the record while the robot's own controller holds it
    applied = len(_policy_frames(r.stack.record, t_engage))
    time.sleep(QUIET_WINDOW_S)
    assert len(_policy_frames(r.stack.record, t_engage)) == applied, "policy frames after the hand-back"
    ev = r.stack.record.events(t_engage)
    print(f"under the policy: {applied} policy frames applied; pelvis at least {lowest_pelvis(ev, t_engage):.2f} m")
    assert lowest_pelvis(ev, t_engage) > STANDING_Z_M and r.stack.position()[2] > STANDING_Z_M
    assert r.stack.modes()[-1].name == "HIGH_LEVEL"

    _policy_verb(d, "unload")
    _policy_answered(d, "policy unload")
    _page_shows(d, "policy-phase", lambda text: text == "UNLOADED")


def _lying_damped(r: Rig) -> None:
    """Damp the robot (the test's own ~/loco_command) and wait until it lies on its back, as the sim reports it and
    the node's body watch has seen it (it reads the attitude at its own rate)."""
    assert r.stack.loco("damp").success
    assert wait_until(lambda: r.stack.sim.get()["body"]["posture"] == "on_back", 10.0), r.stack.sim.get()["body"]
    time.sleep(0.5)


def _recovery_calls(record: SimRecord, since: float) -> list[tuple[int, int]]:
    """SetFsmId and SetBalanceMode requests the robot received since ``since``: (api, the value asked)."""
    return [(e["api"], fsm_of(e) if e["api"] == api_ids.LOCO_SET_FSM_ID else json.loads(e["p"])["data"])
            for e in requests(record.events(since)) if e["api"] in (api_ids.LOCO_SET_FSM_ID, api_ids.LOCO_SET_BALANCE_MODE)]


def test_recover_gets_a_robot_lying_damped_up_step_by_step_and_a_second_click_is_refused(rig: Rig) -> None:
    r, d = rig, rig.driver
    d.get(r.console.url + f"?token={TOKEN}")  # the console the test before the planner's started, with a token
    _page_shows(d, "mode-name", lambda text: text == "HIGH_LEVEL")
    _lying_damped(r)
    t_click = _click(d, "#recover")
    _page_shows(d, "recover-steps", lambda text: "get_up: sent" in text, 10.0)
    _click(d, "#recover")  # again, while it runs: refused, not queued
    refused = _page_shows(d, "recover-answer", lambda text: "REFUSED" in text, 5.0)
    assert "already running" in refused and "get_up" in refused, refused
    end = _page_shows(d, "recover-answer", lambda text: "the robot stands" in text or "failed at" in text, 30.0)
    shown = _text(d, "recover-steps").splitlines()
    print(f"the page: {end}\n  " + "\n  ".join(shown))
    assert "the robot stands" in end, end
    assert [line.split(":")[0] for line in shown] == ["high_level", "damp", "get_up", "balance_stand"]
    assert all(": done after " in line for line in shown), shown
    assert "lie_to_stand (lying_back)" in shown[2], shown
    assert _recovery_calls(r.stack.record, t_click) == RECOVERY_CALLS, "the robot got other calls than one recovery's"
    events = r.stack.record.events(t_click)
    sent_702 = next(e["t"] for e in requests(events, api_ids.LOCO_SET_FSM_ID) if fsm_of(e) == FsmId.LIE_TO_STAND)
    seen = [e for e in states(events) if e["fsm"] == FsmId.LIE_TO_STAND]
    up = min(e["t"] for e in seen if e["fsm_mode"] == FsmMode.STATIC)
    balance = requests(events, api_ids.LOCO_SET_BALANCE_MODE)[0]["t"]
    heights = [(e["t"], e["z"]) for e in events if e["k"] == "body"]
    lying_z = max(z for t, z in heights if t <= sent_702)
    standing_z = min(z for t, z in heights if t >= balance)
    print(f"on the record: 702 {sent_702 - t_click:.2f} s after the click, standing at 702 after "
          f"{up - t_click:.2f} s, SetBalanceMode after {balance - t_click:.2f} s; pelvis {lying_z:.2f} m lying, "
          f"at least {standing_z:.2f} m once balanced")
    assert any(e["fsm_mode"] == FsmMode.DYNAMIC for e in seen) and up < balance, seen
    assert lying_z < 0.4 and standing_z > 0.7
    assert r.stack.sim.get()["sport"]["fsm_id"] == FsmId.LIE_TO_STAND and r.stack.sim.get()["body"]["posture"] == "upright"
    assert r.stack.modes()[-1].name == "HIGH_LEVEL", "the get-up tripped a body check"


def test_a_wrong_token_is_refused_and_the_e_stop_preempts_a_running_recovery_and_damps_the_robot(rig: Rig) -> None:
    r, d = rig, rig.driver
    assert http_get(r.console.url + "?token=wrong")[0] == 401
    d.get(r.console.url + "?token=wrong")
    assert "401" in d.find_element("tag name", "body").text
    assert not d.find_elements("id", "estop")  # nothing of the page
    d.get(r.console.url + f"?token={TOKEN}")
    _page_shows(d, "mode-name", lambda text: text == "HIGH_LEVEL")
    _lying_damped(r)
    t_recover = _click(d, "#recover")
    getting_up = lambda: any(e["fsm"] == FsmId.LIE_TO_STAND for e in states(r.stack.record.events(t_recover)))  # noqa: E731
    assert wait_until(getting_up, 10.0), "no get-up on the record"
    time.sleep(1.0)  # well inside the get-up: the recovery waits for lie_to_stand's answer
    t_estop = _click(d, "#estop")
    answer = _page_shows(d, "estop-answer", lambda text: "success=" in text, 20.0)
    assert "success=true" in answer and "damped" in answer, answer
    end = _page_shows(d, "recover-answer", lambda text: "failed at" in text, 10.0)
    assert "failed at get_up" in end and "preempted by e-stop" in end, end
    assert "FAILED" in _text(d, "recover-steps").splitlines()[2]
    assert not requests(r.stack.record.events(t_recover), api_ids.LOCO_SET_BALANCE_MODE), "a step after the e-stop"
    assert any(is_damp(e) for e in requests(r.stack.record.events(t_estop))), "no Damp after the e-stop"
    assert any(damped(s) for s in states(r.stack.record.events(t_estop))), "the robot was never damped with 'ai'"
    status = r.stack.sim.get()["sport"]
    assert status["fsm_id"] == 1 and status["mode"] == "ai"
    _page_shows(d, "mode-name", lambda text: text == "EMERGENCY", 5.0)
    _page_shows(d, "damp", lambda text: text == "damp_confirmed", 5.0)
    colour = "return getComputedStyle(document.getElementById('mode-name')).color"
    assert wait_until(lambda: d.execute_script(colour) == "rgb(255, 0, 0)", 5.0), d.execute_script(colour)  # the LED's
    last = lambda: r.stack.modes()[-1]  # noqa: E731
    assert wait_until(lambda: last().name == "EMERGENCY" and last().damp_confirmed, 5.0), last()
    time.sleep(1.0 if r.shots else 0.0)
    _shot(r, "console_emergency.png")


#: The Last incident card's plots, each with its lines' colours (incident.js), as the canvas has them: lines that lie
#: on one another (a robot at rest: every velocity 0) show the last drawn, so a plot counts its colours together.
INCIDENT_PLOTS = {"plot-incident-tilt": [(255, 138, 101)],
                  "plot-incident-velocity": [(77, 163, 255), (60, 207, 110), (180, 140, 255), (242, 193, 78)]}
#: More pixels of its lines' colours than the legend's swatches have (10 x 3 each): a line across the plot.
DRAWN_PIXELS = 300
#: The e-stop's steps the card lists, as the node records them (docs/recorder.md), in this order; the last two land
#: in the file only if they came within its after-window (recorder_after_s: INCIDENT_AFTER_S).
ESTOP_STEPS = ("DampNoReply sent", "e-stop request", "EMERGENCY entered", "Damp request", "Damp answer")
LATER_STEPS = ("damp_confirmed", "e-stop answer")
#: Pixels of one colour on a canvas.
PIXELS = """const c = document.getElementById(arguments[0]);
const px = c.getContext("2d").getImageData(0, 0, c.width, c.height).data;
let n = 0;
for (let i = 0; i < px.length; i += 4) {
  if (px[i] === arguments[1] && px[i + 1] === arguments[2] && px[i + 2] === arguments[3]) n++;
}
return n;"""


def test_the_incident_card_shows_the_e_stops_incident_and_its_download_is_the_file_on_disk(rig: Rig) -> None:
    from selenium.webdriver.common.by import By

    r, d = rig, rig.driver
    emergencies = lambda: [f for f in list_incidents(r.incidents) if f.cause is Cause.EMERGENCY]  # noqa: E731
    assert wait_until(lambda: bool(emergencies()), INCIDENT_AFTER_S + INCIDENT_WRITE_S), list(r.incidents.iterdir())
    newest = list_incidents(r.incidents)[-1]
    assert newest == emergencies()[-1], list_incidents(r.incidents)
    # the page was opened before the file existed: the card took it up by itself
    assert newest.path.stat().st_mtime * 1000 > d.execute_script("return performance.timeOrigin")
    cause = _page_shows(d, "incident-cause", lambda text: text.startswith("EMERGENCY"), RECORD_WAIT_S)
    assert cause == f"EMERGENCY from HIGH_LEVEL ({r.stack.ns}/g1_mode_manager/estop)", cause
    assert _text(d, "incident-mode") == "EMERGENCY"
    link = d.find_element(By.ID, "incident-download")
    assert newest.path.name in link.text and link.get_attribute("download") is not None

    # the plot has data: the series the page holds, and their lines drawn
    series = d.execute_script("return incidentCard.incident.series")
    print("incident series: " + ", ".join(f"{k} {len(p)} in {min((v for _t, v in p), default=None)}.."
                                          f"{max((v for _t, v in p), default=None)}" for k, p in series.items()))
    assert len(series["tilt"]) > 100 and series["meas_vx"], {k: len(v) for k, v in series.items()}
    assert max(v for _t, v in series["tilt"]) > 0.3  # the robot got up from lying on its back in the window
    modes = d.execute_script("return incidentCard.incident.modes")
    assert modes[-1][1] == "EMERGENCY" and abs(modes[-1][0]) <= 0.002 and modes[-2][1] == "HIGH_LEVEL", modes
    for canvas, colours in INCIDENT_PLOTS.items():
        drawn = [d.execute_script(PIXELS, canvas, *colour) for colour in colours]
        assert sum(drawn) > DRAWN_PIXELS, (canvas, drawn)

    # the e-stop's steps, in order, each with its time from the stop
    shown = [(li.get_attribute("data-step"), float(li.get_attribute("data-t")), li.text)
             for li in d.find_elements(By.CSS_SELECTOR, "#incident-steps li")]
    print("the card's e-stop steps:\n  " + "\n  ".join(text for *_, text in shown))
    names = [name for name, _t, _text in shown]
    assert [name for name in names if name in ESTOP_STEPS] == list(ESTOP_STEPS), names
    at = {name: t for name, t, _text in reversed(shown)}  # each step's first time
    assert abs(at["e-stop request"]) < 1.0 and abs(at["EMERGENCY entered"]) <= 0.002
    later = [at[name] for name in LATER_STEPS if name in at]
    # after the entry (its time and the file's began are both to the millisecond)
    assert -0.002 <= at["Damp request"] <= at["Damp answer"] and all(t >= at["Damp answer"] for t in later), at
    for name, t, text in shown:  # as the page shows it: "+0.012 s · Damp answer: code 0, 3 ms"
        when, _, rest = text.partition(" s · ")
        assert float(when) == pytest.approx(t, abs=1e-9) and rest.startswith(name), (name, t, text)
    assert next(text for name, _t, text in shown if name == "Damp answer").split(": ", 1)[1].startswith("code 0")

    # the download: the same bytes as the file on disk, as an attachment
    status, headers, body = _download(link.get_attribute("href"))
    assert status == 200 and body == newest.path.read_bytes()
    assert headers["Content-Disposition"] == f'attachment; filename="{newest.path.name}"'
    _shot(r, "console_incident.png", height=1500, card="incident-card")


def _download(url: str) -> tuple[int, Mapping[str, str], bytes]:
    """(status, headers (any case), body) of the link's URL (its token in it), fetched as a script would."""
    import asyncio

    import aiohttp

    async def go() -> tuple[int, Mapping[str, str], bytes]:
        async with aiohttp.ClientSession() as session, session.get(url) as response:
            return response.status, response.headers.copy(), await response.read()

    return asyncio.run(go())
