"""A chaos scenario's plan, drawn from its seed: robot faults, the operators' actions, and where the e-stop aims.

Each scenario aims its e-stop at one coverage cell (coverage.py), taken in turn by seed so that any run of
consecutive seeds at least as long as the cell list aims at every cell. Random noise comes first (mode
requests, loco commands, streams, body faults, clears from two or three clients; 2 to 40 actions over up to
about 25 s by the scenario's length), then the *setup* brings the node to the aimed row (a mode, FAULT, or a
transition kept long by injected delays), then the *column* action (a mode call, a loco command, a stream)
starts once the row is reached; the e-stop goes out when both hold (or at the deadline: the landing is
whatever was observed then, never the aim). A policy column's setup loads a walking policy and shadows it in the
row (IDLE, HIGH_LEVEL), or engages it from HIGH_LEVEL (the LOW_LEVEL rows); the noise calls the policy's lifecycle
verbs at random too (chaos/policy.py). Some scenarios also SIGKILL the node during the noise and start
a fresh one, and some send a second e-stop after the first.

Every scenario runs one of LOW_LEVEL's two paths (``low_level_path``), by the parity of its seed, so that any run
of twice as many consecutive seeds as there are cells aims at every cell on each path. On the user_ctrl path the
sim plays a firmware drawn from its options (mostly one that accepts the switch, sometimes one that refuses it
here or does not implement it), the switch takes a random time to show fsm 1000 (sometimes longer than the node
waits), SwitchToUserCtrl and SwitchToInternalCtrl answer late, and the transitions aimed at include the ways out
of LOW_LEVEL (to HIGH_LEVEL and to IDLE), with the user's stream stopping before them (silence).

Both sources of the Move stream drive in the scenarios: the teleop (/cmd_vel, the "drive" stream) and a planner
publishing the autonomy's cmd_vel_nav at 20 Hz with a command of its own shape (drivers.py), which passes only
once an operator handed it the robot. The noise hands over, takes over (``~/take_over`` and the teleop's commands)
and runs the planner at random instants, racing the mode requests; a setup aimed at HIGH_LEVEL plays a *script* of
the two, each in turn by seed (the planner driving at the e-stop, a teleop takeover, a take_over service call, the
planner falling silent and the human taking over), and the e-stop waits for it; a setup that leaves HIGH_LEVEL (to
IDLE, LOW_LEVEL or FAULT) often hands over first, so that the autonomy drives when it is left; and some e-stops go
out together with a hand-over or a take-over. These draws come from a random generator of their own, so a seed's
other draws are what they were before.

Everything random comes from the seed, so a failure is replayed with `make chaos SEED=<seed> N=1`.
"""

from __future__ import annotations

import random
from dataclasses import dataclass, field
from typing import Any

from chaos import policy
from chaos.coverage import REQUIRED
from g1_mode_manager.protocol import api_ids

#: Per-api delays the sim may inject (the robot's slow calls), s; node call timeouts exceed the maximum.
DELAYED_APIS = (api_ids.MS_CHECK_MODE, api_ids.MS_SELECT_MODE, api_ids.MS_RELEASE_MODE, api_ids.LOCO_SET_FSM_ID)
#: ... and on the user_ctrl path the switches too.
USER_CTRL_APIS = (api_ids.LOCO_SWITCH_TO_USER_CTRL, api_ids.LOCO_SWITCH_TO_INTERNAL_CTRL)
#: LOW_LEVEL's two paths; a scenario's is PATHS[seed % 2].
PATHS = ("release", "user_ctrl")
#: The firmware the sim plays on the user_ctrl path, drawn with these weights: mostly one that takes the switch.
FIRMWARES = ("either",) * 5 + ("from_walkrun", "from_damp", "none")
#: How long the sim's switch takes to show fsm 1000, s: sometimes past the node's user_ctrl_switch_timeout_s (1 s).
USER_CTRL_DELAY_S = (0.0, 1.4)
#: The longest per-api delay of the noise, by scenario length, s. A short scenario (the suite's batch) draws them up
#: to 1.5 s: still hundreds of times a loopback call, so in-flight calls land in every order, while an e-stop that
#: must wait out a delayed CheckMode, SelectMode and a failing Damp in turn is not kept 10 s; the longer lengths
#: (`make chaos`) keep the robot's multi-second calls.
MAX_DELAY_S = {"short": 1.5, "medium": 3.0, "long": 3.0}
#: A transition aimed at is kept in progress this long at least by delaying its calls, s.
TRANSITION_DELAY_S = (1.0, 2.5)
MODES = ("idle", "high_level", "low_level")
LOCO = ("stand_up", "start", "zero_torque", "squat", "balance_stand", "lie_to_stand", "damp")
#: Noise actions, with their weights: mode requests, loco commands, /cmd_vel, arm and joint streams, a body
#: fault made true in the sim, an operator's clear_fault, a policy's lifecycle verb.
KINDS = ("mode", "mode", "loco", "drive", "arm", "lowcmd", "body", "body", "clear", "policy")
STREAMS = ("drive", "arm", "lowcmd")
#: The noise before a policy is engaged for a LOW_LEVEL row: what leaves the robot standing as it booted. The engage
#: is refused while the policy's shadow disagrees with the measured pose (a robot damped, fallen, squatting or with
#: its arms raised), so the rest of the noise would turn most such aims into a refusal.
CALM_KINDS = ("mode", "mode", "drive", "clear", "policy")
CALM_MODES = ("idle", "high_level")
BODY_FAULTS = ("push", "overheat", "battery", "remote", "freeze")
#: How long a transient body fault (a held key, a frozen stream) lasts, s.
TRANSIENT_S = (0.3, 1.5)
#: Scenario lengths: (weight, noise actions, noise span s, noise clients).
LENGTHS = {"short": (6, (0, 4), 2.0, 2), "medium": (3, (8, 16), 8.0, 2), "long": (1, (20, 40), 25.0, 3)}
#: After the setup starts, the e-stop goes out at the latest this much later (the aim missed), s.
AIM_DEADLINE_S = 9.0
#: Clients: the noise uses 0..2, the setup SETUP, the column action COLUMN.
SETUP, COLUMN = 3, 4
#: On the user_ctrl path, a user's controller streaming ~/lowcmd from the setup's start on (silence hands the robot
#: back within lowcmd_timeout_s: LOW_LEVEL lasts only while someone streams).
USER_STREAM = 5
#: The planner, publishing the autonomy's input (cmd_vel_nav) beside the operators.
PLANNER = 6
#: Who drives, in the noise: hand-overs, take-overs, the teleop's commands (a takeover while the planner drives), the
#: planner's streams; with these weights.
DRIVE_KINDS = ("hand_over", "hand_over", "take_over", "drive", "planner")
#: A planner stream in the noise lasts this long, s; the setup's runs until the scenario ends.
PLANNER_S = (0.5, 3.0)
#: The planner's command, drawn per scenario: ahead, to the left and turning right (the shape the judge knows it
#: by), at times past the autonomy's limits (0.5 m/s, 0.3 m/s, 0.8 rad/s) so that its clamps are judged.
PLANNER_COMMAND = ((0.2, 0.7), (0.05, 0.4), (-1.0, -0.1))
#: A setup aimed at HIGH_LEVEL plays one of these, in turn by seed; the e-stop waits until it has played. As
#: connected the robot is in no walking fsm and refuses Moves (the node's ramp stays at its first step); "autonomy"
#: starts it walking first.
SCRIPTS = ("autonomy", "teleop", "take_over", "silent")
#: ... a setup that leaves HIGH_LEVEL hands over first this often.
LEAVE_HANDED_OVER = 0.6
#: A hand-over or a take-over sent together with the e-stop, this often.
RACES = ("hand_over", "take_over")
RACE_SHARE = 0.2
#: The planner's silence in the "silent" script: past autonomy_timeout_s (0.5 s) and ~/mode's change check, s.
SILENCE_S = 0.8
#: Separates the drive draws' generator from the plan's.
DRIVE_SALT = 0xD21BE
#: A body fault that puts every mode in FAULT: a winding at 140 °C (past the 135 °C critical limit).
FAULT_HEAT = {"motor_temperature": {"4": [70, 140]}}


@dataclass
class Plan:
    seed: int
    faults: dict[str, Any]
    actions: list[tuple[float, int, str, Any]]  # (at s, client, kind, argument): the noise and the setup
    aim: tuple[str, str]  # the coverage cell the e-stop aims at
    column_action: tuple[str, Any] | None  # (kind, argument) started once the aimed row is reached
    setup_at: float  # when the setup starts (the noise is over), s
    estop_via: str  # "service", "topic_reliable", "topic_best_effort"
    damp_fails: int
    length: str = "short"
    gantry: bool = False  # the robot hangs in the sim's gantry (then a limp LOW_LEVEL robot does not fall)
    kill_at: float | None = None  # SIGKILL the node then (during the noise) and start a fresh one
    second_estop_after: float | None = None  # a second e-stop this long after the first went out
    second_via: str = "service"
    path: str = "release"  # low_level_path: "release" or "user_ctrl"
    node_params: tuple[str, ...] = ()  # the scenario's node's parameters (its path, its reaction to silence)
    planner_command: tuple[float, float, float] = (0.4, 0.2, -0.5)  # what the planner publishes (vx, vy, wz)
    script: str | None = None  # what the setup does with the two sources: one of SCRIPTS, "leave", or None
    race: str | None = None  # "hand_over" or "take_over": sent together with the e-stop
    extra: dict[str, Any] = field(default_factory=dict)


def _body_fault(rng: random.Random) -> dict[str, Any]:
    """One body fault as the sim's faults keys, with how long it lasts (None: to the scenario's end)."""
    kind = rng.choice(BODY_FAULTS)
    lasts = round(rng.uniform(*TRANSIENT_S), 3)
    if kind == "push":
        push = {"force": round(rng.uniform(50, 700)), "direction": round(rng.uniform(-3.14, 3.14), 3),
                "duration": round(rng.uniform(0.1, 0.4), 3)}
        return {"set": {"push": push}, "lasts": None}
    if kind == "overheat":
        motor, hot = str(rng.randrange(29)), rng.choice([(60, 125), (90, 60), (70, 140), (100, 60)])
        return {"set": {"motor_temperature": {motor: list(hot)}}, "lasts": None}
    if kind == "battery":
        return {"set": {"battery_soc": round(rng.uniform(3, 19), 1)}, "lasts": None}
    if kind == "remote":
        return {"set": {"remote_keys": ["L2", "B"]}, "lasts": lasts}
    return {"set": {"freeze_lowstate": True}, "lasts": lasts}


def _noise_kinds(length: str, calm: bool) -> tuple[str, ...]:
    """The noise's kinds: a short scenario's (the suite's batch) without the policy's verbs, whose model loads and 50 Hz
    shadows load the suite's two cores; the aimed policy cells load one still."""
    kinds = CALM_KINDS if calm else KINDS
    return kinds if length != "short" else tuple(k for k in kinds if k != "policy")


def _noise(rng: random.Random, length: str, calm: bool = False) -> tuple[list[tuple[float, int, str, Any]], float]:
    """Random operator actions (``calm``: only those that leave the robot standing); returns them and when they
    end."""
    _, (lo, hi), span, clients = LENGTHS[length]
    count = rng.randint(lo, hi)
    actions = []
    for _ in range(count):
        at = round(rng.uniform(0.05, span), 3)
        kind = rng.choice(_noise_kinds(length, calm))
        arg: Any = ""
        if kind == "mode":
            arg = rng.choice(CALM_MODES if calm else MODES)
        elif kind == "loco":
            arg = rng.choice(LOCO)
        elif kind in STREAMS:
            arg = round(rng.uniform(0.3, 1.5), 2)
        elif kind == "policy":
            arg = policy.noise_verb(rng)
        elif kind == "body":  # after the node's first connect: before it, no check acts
            arg = _body_fault(rng)
            at = max(at, round(rng.uniform(1.8, 2.6), 3))
        actions.append((at, rng.randrange(clients), kind, arg))
    actions.sort(key=lambda a: a[0])
    end = max((a[0] for a in actions), default=0.0)
    return actions, end + (0.3 if actions else 0.05)


def _drive_noise(rng: random.Random, noise: list[tuple[float, int, str, Any]],
                 length: str) -> list[tuple[float, int, str, Any]]:
    """Who drives, in the noise's span: hand-overs, take-overs and teleop commands from the noise's clients, and the
    planner, either publishing all along or in a few streams."""
    if not noise:
        return []
    end, clients = noise[-1][0], LENGTHS[length][3]
    actions: list[tuple[float, int, str, Any]] = []
    if rng.random() < 0.5:
        start = round(rng.uniform(0.05, min(1.0, end)), 3)
        actions.append((start, PLANNER, "planner", round(end - start + rng.uniform(*PLANNER_S), 2)))
    for _ in range(rng.randint(0, max(1, len(noise) // 3))):
        kind, at = rng.choice(DRIVE_KINDS), round(rng.uniform(0.05, end), 3)
        if kind == "planner":
            actions.append((at, PLANNER, kind, round(rng.uniform(*PLANNER_S), 2)))
        else:
            actions.append((at, rng.randrange(clients), kind, round(rng.uniform(0.3, 1.5), 2) if kind == "drive" else ""))
    return actions


def _script(script: str, rng: random.Random) -> list[tuple[float, str, Any]]:
    """The steps a setup aimed at HIGH_LEVEL takes once there (after its mode request)."""
    def pause(lo: float, hi: float) -> tuple[float, str, Any]:
        return (0.0, "pause", round(rng.uniform(lo, hi), 3))

    handed = [(0.0, "hand_over", ""), pause(0.1, 0.3)]  # the planner's Moves reach the robot within 0.1 s
    if script == "teleop":  # the teleop takes the robot; the planner drives again only once handed it again
        return [*handed, (0.0, "drive", round(rng.uniform(0.15, 0.3), 2)), *handed]
    if script == "take_over":
        return [*handed, (0.0, "take_over", ""), pause(0.1, 0.3), *handed]
    if script == "silent":  # then the human takes the robot back from the silent planner, by either way
        back = rng.choice([(0.0, "take_over", ""), (0.0, "drive", round(rng.uniform(0.15, 0.3), 2))])
        return [*handed, (0.0, "planner_off", ""), (0.0, "pause", SILENCE_S), back]
    # the robot walking (its Moves acknowledged: the autonomy's ramp judged), the planner up to speed (0.5 s)
    return [(0.0, "loco", "start"), (0.0, "hand_over", ""), pause(0.2, 0.8)]


def _with_drivers(setup: list[tuple[float, str, Any]], row: str, seed: int,
                  rng: random.Random) -> tuple[list[tuple[float, str, Any]], str | None]:
    """The setup with who drives in it, and its script: aimed at HIGH_LEVEL, a script in turn by seed (mixed with
    the cell, so that every window of a few cell lists plays each on the row's cells); through HIGH_LEVEL to
    another row, often a hand-over right after HIGH_LEVEL was reached."""
    if row == "HIGH_LEVEL":
        script = SCRIPTS[(seed // len(REQUIRED) + seed % len(REQUIRED)) % len(SCRIPTS)]
        return [*setup, *_script(script, rng)], script
    at = [i for i, (_, kind, arg) in enumerate(setup) if (kind, arg) == ("mode", "high_level")]
    if not at or at[0] == len(setup) - 1 or row == "->HIGH_LEVEL" or rng.random() >= LEAVE_HANDED_OVER:
        return setup, None
    return [*setup[:at[0] + 1], (setup[at[0]][0], "hand_over", ""), *setup[at[0] + 1:]], "leave"


def _delay(delays: dict[str, Any], rng: random.Random, *apis: int) -> None:
    for api in apis:
        delays[str(api)] = [TRANSITION_DELAY_S[0], round(rng.uniform(*TRANSITION_DELAY_S), 3)]


def _setup(row: str, rng: random.Random, delays: dict[str, Any]) -> list[tuple[float, str, Any]]:
    """The setup's actions for ``row``, at offsets from the setup's start (one client, in order)."""
    check, select, release = api_ids.MS_CHECK_MODE, api_ids.MS_SELECT_MODE, api_ids.MS_RELEASE_MODE
    if row == "UNINITIALIZED":
        return []
    if row in ("IDLE", "HIGH_LEVEL", "LOW_LEVEL"):
        return [(0.0, "mode", row.lower())]
    if row == "FAULT":
        return [(0.0, "mode", rng.choice(MODES)), (0.3, "body", {"set": FAULT_HEAT, "lasts": None})]
    if row == "->HIGH_LEVEL":
        start = rng.choice(["idle", "low_level"] * 3 + [""])  # "": the first connect is the transition
        _delay(delays, rng, check, select)
        return [*([(0.0, "mode", start)] if start else []), (0.0, "mode", "high_level")]
    if row == "->LOW_LEVEL":
        start = rng.choice(["idle", "high_level"] * 3 + [""])
        _delay(delays, rng, check, release)
        return [*([(0.0, "mode", start)] if start else []), (0.0, "mode", "low_level")]
    # ->IDLE: the first connect, or HIGH_LEVEL -> IDLE while the arms ramp out (up to 2 s)
    if rng.random() < 0.25:
        return [(0.0, "mode", "idle")]
    return [(0.0, "mode", "high_level"), (0.0, "arm", 2.5), (0.0, "mode", "idle")]


def _user_ctrl_setup(row: str, column: str, rng: random.Random,
                     delays: dict[str, Any]) -> tuple[list[tuple[float, str, Any]], float | None, bool]:
    """The setup on the user_ctrl path: (its steps, [] where the release path's serve; how long a user's stream
    runs from the setup's start, or None; whether the node damps on silence instead of handing back).

    LOW_LEVEL is held by a stream, or by ``user_ctrl_silence: damp`` where nothing may be in flight. The ways in
    and out are kept long by the robot: SwitchToUserCtrl answered late on the way in; on the way out
    SwitchToInternalCtrl answered late, requested after a pause in LOW_LEVEL while the stream may already have
    stopped (its silence races the request)."""
    into, out = api_ids.LOCO_SWITCH_TO_USER_CTRL, api_ids.LOCO_SWITCH_TO_INTERNAL_CTRL
    if row == "LOW_LEVEL":
        if column == "nothing":
            return [(0.0, "mode", "low_level")], None, True
        return [(0.0, "mode", "low_level")], AIM_DEADLINE_S + 5.0, rng.random() < 0.25
    if row == "->LOW_LEVEL":
        _delay(delays, rng, into)
        start = rng.choice(["idle", "high_level", "high_level"])
        return [(0.0, "mode", start), (0.0, "mode", "low_level")], None, rng.random() < 0.25
    if row in ("->HIGH_LEVEL", "->IDLE") and rng.random() < 0.5:
        _delay(delays, rng, out)
        target = row.removeprefix("->").lower()
        steps = [(0.0, "mode", "low_level"), (0.0, "pause", round(rng.uniform(0.2, 1.0), 3)), (0.0, "mode", target)]
        return steps, round(rng.uniform(1.0, 6.0), 3), rng.random() < 0.25
    return [], None, rng.random() < 0.25


def _policy_setup(row: str, path: str, rng: random.Random, delays: dict[str, Any]) -> list[tuple[float, str, Any]]:
    """The setup of a policy column: the row's mode (HIGH_LEVEL for the LOW_LEVEL rows: the engage enters
    LOW_LEVEL), then the policy's steps; into LOW_LEVEL kept long by the robot as for a mode request."""
    if row == "->LOW_LEVEL":
        if path == "user_ctrl":
            _delay(delays, rng, api_ids.LOCO_SWITCH_TO_USER_CTRL)
        else:
            _delay(delays, rng, api_ids.MS_CHECK_MODE, api_ids.MS_RELEASE_MODE)
    return [(0.0, "mode", "idle" if row == "IDLE" else "high_level"), *policy.setup_steps(row, rng)]


def _column_action(column: str, row: str, rng: random.Random) -> tuple[str, Any] | None:
    if column in ("nothing", "policy"):  # a policy is put at work by the setup (_policy_setup)
        return None
    if column == "mode call":
        # in a settled row: a request that is refused or starts a transition; the e-stop goes out with it
        return ("mode", rng.choice([m for m in MODES if m != row.lower()] or list(MODES)))
    if column == "loco command":
        return ("loco", rng.choice(LOCO))
    kind = {"HIGH_LEVEL": "drive", "LOW_LEVEL": "lowcmd", "->LOW_LEVEL": "lowcmd"}.get(row, rng.choice(STREAMS))
    if row in ("HIGH_LEVEL", "->IDLE") and rng.random() < 0.5:
        kind = "arm"
    return (kind, 3.0)


def _gantry(row: str, rng: random.Random, setup: list[tuple[float, str, Any]], path: str) -> bool:
    """Hung in the gantry, or free. LOW_LEVEL is limp on the release path, and on the user_ctrl path the
    operators' stream holds one joint (the others damped): a free robot falls within a second there, and a body
    check turns the aimed row into FAULT; so a row in or into LOW_LEVEL, or a setup through it, is aimed at hung.
    A policy engaged on the user_ctrl path balances the robot it drives: there, free half of the time."""
    steps = [(kind, arg) for _, kind, arg in setup]
    if ("policy", "engage") in steps and path == "user_ctrl":
        return rng.random() < 0.5
    through_low = ("mode", "low_level") in steps or ("policy", "engage") in steps
    return row in ("LOW_LEVEL", "->LOW_LEVEL") or through_low or rng.random() < 0.5


def path_of(seed: int, paths: tuple[str, ...] = PATHS) -> str:
    """The LOW_LEVEL path of scenario ``seed``, among ``paths``."""
    return paths[seed % len(paths)]


def plan(seed: int, lengths: tuple[str, ...] = tuple(LENGTHS), paths: tuple[str, ...] = PATHS) -> Plan:
    rng = random.Random(seed)
    aim = REQUIRED[seed % len(REQUIRED)]
    row, column = aim
    path = path_of(seed, paths)
    length = rng.choices(lengths, weights=[LENGTHS[n][0] for n in lengths])[0]
    delays: dict[str, Any] = {}
    for api in DELAYED_APIS + (USER_CTRL_APIS if path == "user_ctrl" else ()):
        if rng.random() < 0.6:
            delays[str(api)] = [0.0, round(rng.uniform(0.1, MAX_DELAY_S[length]), 3)]
    damp_fails = rng.choice([0, 0, 0, 1, 2])
    faults: dict[str, Any] = {"delay_s": delays, "seed": seed, "damp_fails": damp_fails}
    calm = column == "policy" and "LOW_LEVEL" in row
    noise, setup_at = ([], 0.05) if row == "UNINITIALIZED" else _noise(rng, length, calm)
    kill_at = None
    if noise and rng.random() < 0.15:
        kill_at = round(rng.uniform(0.2, setup_at), 3)
    if column == "policy":
        setup, stream_s, damp_on_silence = _policy_setup(row, path, rng, delays), None, (
            path == "user_ctrl" and rng.random() < 0.25)
    elif path == "user_ctrl":
        setup, stream_s, damp_on_silence = _user_ctrl_setup(row, column, rng, delays)
    else:
        setup, stream_s, damp_on_silence = [], None, False
    setup = setup or _setup(row, rng, delays)
    if path == "user_ctrl":
        # a setup through LOW_LEVEL needs a firmware that takes the switch; elsewhere the noise's requests for
        # LOW_LEVEL meet every firmware
        steps = [(kind, arg) for _, kind, arg in setup]
        through_low = (("mode", "low_level") in steps or ("policy", "engage") in steps) and row != "->LOW_LEVEL"
        faults |= {"user_ctrl": "either" if through_low else rng.choice(FIRMWARES),
                   "user_ctrl_delay_s": round(rng.uniform(*USER_CTRL_DELAY_S) * (0.6 if through_low else 1.0), 3)}
    drive_rng = random.Random(seed ^ DRIVE_SALT)
    setup, script = _with_drivers(setup, row, seed, drive_rng)
    actions = [*noise, *_drive_noise(drive_rng, noise, length),
               *((round(setup_at + dt, 3), SETUP, kind, arg) for dt, kind, arg in setup)]
    if stream_s is not None:
        actions.append((setup_at, USER_STREAM, "lowcmd", stream_s))
    if script is not None:  # the planner publishes from the setup's start to the scenario's end
        actions.append((setup_at, PLANNER, "planner", AIM_DEADLINE_S + 5.0))
    actions.sort(key=lambda a: a[0])
    command = tuple(round(drive_rng.uniform(*span), 2) for span in PLANNER_COMMAND)
    race = drive_rng.choice(RACES) if drive_rng.random() < RACE_SHARE else None
    node_params = (f"low_level_path:={path}", *(["user_ctrl_silence:=damp"] if damp_on_silence else []))
    second = round(rng.uniform(0.0, 1.5), 3) if rng.random() < 0.25 else None
    vias = ["service", "service", "topic_reliable", "topic_best_effort"]
    return Plan(seed, faults, actions, aim, _column_action(column, row, rng), setup_at, rng.choice(vias), damp_fails,
                length=length, gantry=_gantry(row, rng, setup, path), kill_at=kill_at, second_estop_after=second,
                second_via=rng.choice(vias), path=path, node_params=node_params,
                planner_command=(command[0], command[1], command[2]), script=script, race=race)
