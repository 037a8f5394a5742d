"""The console process on its own (no robot, no mode manager: a stand-in publishes ~/mode, takes cmd_vel and
serves the drivers' services and some of the policy's), spoken to as a browser would over HTTP and a WebSocket:
who gets in, what bad input does, who drives, what the policy card calls."""

from __future__ import annotations

import asyncio
import json
import time
from collections.abc import Iterator

import pytest

from support.console import Console, FakeManager, RawPage, http_get, start_console
from support.mode_manager import wait_until

TOKEN = "correct-horse-battery-staple"
DEADLINE_S = 0.3  # the console's heartbeat_deadline_s (default)
PUBLISH_PERIOD_S = 0.05  # its publish_rate_hz 20


def _handshake_status(url: str, headers: dict[str, str] | None = None) -> int:
    """The HTTP status a WebSocket handshake gets (101 once upgraded)."""
    import aiohttp

    async def go() -> int:
        async with aiohttp.ClientSession() as session:
            try:
                ws = await session.ws_connect(url, headers=headers or {})
            except aiohttp.WSServerHandshakeError as exc:
                return exc.status
            await ws.close()
            return 101

    return asyncio.run(go())


@pytest.fixture(scope="module")
def manager() -> Iterator[FakeManager]:
    fake = FakeManager("HIGH_LEVEL")
    yield fake
    fake.close()


@pytest.fixture(scope="module")
def console(manager: FakeManager) -> Iterator[Console]:
    c = start_console()
    yield c
    assert c.proc.stop() == 0, c.proc.output()


def test_a_bind_beyond_loopback_without_a_token_does_not_start() -> None:
    with pytest.raises(RuntimeError, match="needs a token"):
        start_console("host:=0.0.0.0").proc.stop()


def test_a_taken_port_is_refused_and_consoles_beyond_max_clients_get_503(console: Console) -> None:
    with pytest.raises(RuntimeError, match="cannot serve on"):
        start_console(f"port:={console.port}").proc.stop()
    small = start_console("max_clients:=1")
    try:
        page = RawPage(small.ws_url())
        try:
            assert _handshake_status(small.ws_url()) == 503
            assert page.wait_for(lambda m: m["type"] == "state" and m["refused"].get("clients") == 1)
        finally:
            page.close()
    finally:
        assert small.proc.stop() == 0


def test_with_a_token_every_request_without_it_gets_401_and_nothing_else(tmp_path) -> None:
    token_file = tmp_path / "token"
    token_file.write_text(TOKEN + "\n")
    c = start_console(f"token_file:={token_file}")
    try:
        for url, headers in ((c.url, None), (c.url + "?token=wrong", None), (c.url + "nothing-here", None),
                             (c.url, {"Authorization": "Bearer wrong"}), (c.url + "?token=", None)):
            status, body = http_get(url, headers)
            assert status == 401, (url, status)
            assert "<html" not in body and "script" not in body  # nothing of the page
        assert _handshake_status(c.ws_url()) == 401
        assert _handshake_status(c.ws_url("wrong")) == 401
        status, body = http_get(c.url + f"?token={TOKEN}")
        assert status == 200 and "E-STOP" in body
        assert http_get(c.url, {"Authorization": f"Bearer {TOKEN}"})[0] == 200
        assert http_get(c.url + f"nothing-here?token={TOKEN}")[0] == 404
        page = RawPage(c.ws_url(TOKEN))
        try:
            assert page.wait_for(lambda m: m["type"] == "hello")["you"].startswith("console 1")
        finally:
            page.close()
    finally:
        c.proc.stop()


def test_pages_of_other_sites_and_rebound_host_names_are_refused(console: Console) -> None:
    assert http_get(console.url, {"Host": "rebound.example.com"})[0] == 403  # DNS rebinding onto 127.0.0.1
    assert _handshake_status(console.ws_url(), {"Origin": "http://evil.example.com"}) == 403
    assert _handshake_status(console.ws_url(), {"Origin": f"http://127.0.0.1:{console.port}"}) == 101


def test_bad_input_is_refused_and_counted_and_the_console_keeps_serving(console: Console, manager: FakeManager) -> None:
    page = RawPage(console.ws_url())
    try:
        page.wait_for(lambda m: m["type"] == "state")
        page.send("not json")
        page.send('{"type": "estop", "pad": "' + "x" * 2000 + '"}')  # above max_message_bytes: refused, socket kept
        page.send('{"type": "self_destruct"}')
        page.send('{"type": "teleop", "visible": true, "focused": true, "vx": 9, "vy": 0, "wz": 0, "seq": 1}')
        page.send(b"\x00\x01binary")
        flood = [json.dumps({"type": "teleop", "visible": True, "focused": True, "vx": 0.0, "vy": 0.0, "wz": 0.0,
                             "seq": i}) for i in range(2000)]
        t_flood = time.monotonic()
        page.send_many(flood)
        flood_s = time.monotonic() - t_flood

        def counted(m: dict) -> bool:
            r = m.get("your_refused", {})
            return (m["type"] == "state" and r.get("malformed") == 2 and r.get("oversized") == 1
                    and r.get("unknown") == 1 and r.get("bad_value") == 1 and r.get("flood", 0) >= 1500)

        page.send({"type": "estop"})  # right after the flood, its bucket empty: an e-stop still goes through
        answer = page.wait_for(lambda m: m["type"] == "answer" and m["to"] == "estop")
        assert "not available" in answer["message"]  # tried (this stand-in serves no ~/estop), not refused
        state = page.wait_for(counted)
        print(f"2000 messages in {flood_s:.2f} s: refused {state['your_refused']}")
        assert page.closed_with is None  # still served
        assert page.last("refused")["kind"] in ("flood", "malformed", "oversized", "unknown", "bad_value")
        # a second page is served as usual while the first goes on; it sees the counts of every page
        other = RawPage(console.ws_url())
        try:
            seen = other.wait_for(lambda m: m["type"] == "state" and m["refused"].get("flood", 0) >= 1500)
            assert seen["consoles"] == 2
            # a frame beyond what the socket reads at all: closed (1009) and counted, the others unaffected
            page.send("x" * 70_000)
            assert wait_until(lambda: page.closed_with is not None, 5.0)
            assert page.closed_with == 1009
            other.wait_for(lambda m: m["type"] == "state" and m["refused"].get("oversized", 0) >= 2)
            assert not manager.twists.seen, "bad input published a cmd_vel"
        finally:
            other.close()
    finally:
        page.close()
    assert console.proc.alive()


def test_one_page_drives_the_other_is_told_who_and_a_silent_page_lets_go(console: Console, manager: FakeManager) -> None:
    first, second = RawPage(console.ws_url()), RawPage(console.ws_url())
    try:
        me = first.wait_for(lambda m: m["type"] == "hello")["you"]
        first.hold(vx=1.0)
        assert wait_until(lambda: manager.twists.seen and manager.twists.seen[-1][1] > 0, 10.0), "the driver never drove"
        t_both = time.monotonic()
        second.hold(vx=-1.0)
        told = second.wait_for(lambda m: m["type"] == "state" and m["teleop"]["driver"] == me
                               and m["teleop"]["why_not"] == f"{me} drives")
        assert not told["teleop"]["you_drive"] and not told["teleop"]["publishing"]
        time.sleep(1.0)
        both = manager.twists.since(t_both)
        assert both and all(vx == pytest.approx(0.5) for _, vx, _, _ in both), "the second page's -1 was published"
        # the driver goes silent, socket open: the heartbeat deadline lets go; the lock is still its own for
        # driver_release_s (2 s), so nothing is published
        t_silent = time.monotonic()
        first.release_beat()
        time.sleep(1.0)
        last = manager.twists.seen[-1][0]
        print(f"last cmd_vel {1000 * (last - t_silent):.0f} ms after the driver's last heartbeat was sent")
        assert last - t_silent <= DEADLINE_S + PUBLISH_PERIOD_S + 0.4, "a silent page went on driving"
        assert not manager.twists.since(t_silent + DEADLINE_S + 0.4)
        # its socket closes: the lock is free at once and the second page drives
        first.close()
        assert wait_until(lambda: any(vx < 0 for _, vx, _, _ in manager.twists.since(t_silent)), 3.0)
        # hidden or blurred: nothing published from the next tick on
        for visible, focused in ((False, True), (True, False)):
            second.hold(vx=-1.0, visible=visible, focused=focused)
            t_hidden = time.monotonic()
            time.sleep(0.6)
            late = [s for s in manager.twists.since(t_hidden) if s[0] > t_hidden + 2 * PUBLISH_PERIOD_S + 0.1]
            assert not late, f"published {len(late)} cmd_vel after visible={visible} focused={focused}"
            t_back = time.monotonic()
            second.hold(vx=-1.0)
            assert wait_until(lambda t=t_back: bool(manager.twists.since(t)), 3.0)
    finally:
        second.close()
        first.close()


def test_nothing_is_published_outside_high_level(console: Console, manager: FakeManager) -> None:
    manager.mode = "IDLE"
    page = RawPage(console.ws_url())
    try:
        page.wait_for(lambda m: m["type"] == "state" and m.get("mode") and m["mode"]["name"] == "IDLE", 5.0)
        t = time.monotonic()
        page.hold(vx=1.0)
        state = page.wait_for(lambda m: m["type"] == "state" and "HIGH_LEVEL" in (m["teleop"]["why_not"] or ""))
        time.sleep(0.5)
        assert not manager.twists.since(t), state["teleop"]
    finally:
        page.close()
        manager.mode = "HIGH_LEVEL"


def test_recover_is_told_to_every_page_and_fails_at_damp_when_the_node_serves_no_loco_command(console: Console) -> None:
    page, other = RawPage(console.ws_url()), RawPage(console.ws_url())
    try:
        steps = page.wait_for(lambda m: m["type"] == "hello")["recover_steps"]
        assert steps == ["high_level", "damp", "get_up", "balance_stand"]
        # the sequence starts from the console's latest ~/mode: the stand-in's HIGH_LEVEL, not an earlier test's IDLE
        page.wait_for(lambda m: m["type"] == "state" and m.get("mode") and m["mode"]["name"] == "HIGH_LEVEL", 5.0)
        page.send({"type": "recover"})
        end = other.wait_for(lambda m: m["type"] == "recover" and m["event"] == "done", 10.0)
        you = page.last("hello")["you"]
        told = [(m["event"], m.get("step")) for m in other.received if m["type"] == "recover"]
        # the stand-in shows HIGH_LEVEL: that step needs no call
        assert told == [("started", None), ("result", "high_level"), ("step", "damp"), ("result", "damp"),
                        ("done", None)], told
        assert end["by"] == you and not end["success"] and end["failed_step"] == "damp"
        assert "not available" in end["message"], end  # tried (this stand-in serves no ~/loco_command), and said why
        page.send('{"type": "recover", "steps": ["lie_to_stand"]}')
        assert page.wait_for(lambda m: m["type"] == "refused")["kind"] == "bad_value"
    finally:
        other.close()
        page.close()


def test_hand_over_and_take_over_call_their_services_and_a_page_that_lets_go_leaves_the_autonomy_alone(
        console: Console, manager: FakeManager) -> None:
    page, other = RawPage(console.ws_url()), RawPage(console.ws_url())
    called = len(manager.called)
    try:
        page.wait_for(lambda m: m["type"] == "state")
        page.send({"type": "hand_over"})
        answer = other.wait_for(lambda m: m["type"] == "answer" and m["to"] == "hand_over")  # every page sees it
        assert answer["success"] and answer["request"] == "hand over to autonomy", answer
        assert answer["message"] == "stand-in hand_over_to_autonomy: the autonomy drives"
        assert manager.called[called:] == ["hand_over_to_autonomy"]
        assert wait_until(lambda: other.states()[-1]["mode"]["driver"] == "autonomy", 5.0)
        # W held on a hidden page and on a blurred one: no cmd_vel (not even a zero) and no take_over
        t_hidden = time.monotonic()
        page.hold(vx=1.0, visible=False)
        other.hold(vx=1.0, focused=False)
        time.sleep(0.6)
        assert not manager.twists.since(t_hidden) and manager.called[called:] == ["hand_over_to_autonomy"]
        assert page.states()[-1]["mode"]["driver"] == "autonomy"
        page.release_beat()
        other.release_beat()
        page.send('{"type": "take_over", "vx": 0.5}')
        assert page.wait_for(lambda m: m["type"] == "refused")["kind"] == "bad_value"
        page.send({"type": "take_over"})
        answer = page.wait_for(lambda m: m["type"] == "answer" and m["to"] == "take_over")
        assert answer["success"] and answer["message"] == "stand-in take_over: the teleop drives", answer
        assert manager.called[called:] == ["hand_over_to_autonomy", "take_over"]
        assert wait_until(lambda: page.states()[-1]["mode"]["driver"] == "teleop", 5.0)
    finally:
        other.close()
        page.close()


def test_the_policy_card_calls_the_policy_services_and_every_page_sees_the_nodes_words(
        console: Console, manager: FakeManager) -> None:
    page, other = RawPage(console.ws_url()), RawPage(console.ws_url())
    called = len(manager.called)
    try:
        hello = page.wait_for(lambda m: m["type"] == "hello")
        assert hello["policy_verbs"] == ["load", "shadow", "engage", "disengage", "hold", "unload"]
        assert {"loco_ppo", "loco_fastsac", "dance_ppo", "dance_fastsac"} <= set(hello["policies"])
        assert len(hello["joints"]) == 29
        shown = page.wait_for(lambda m: m["type"] == "state")["policy"]
        assert shown["status"]["phase"] in ("unloaded", "loaded") and shown["joints"] is None
        page.send({"type": "policy", "verb": "engage", "policy": "loco_ppo"})  # only load names a policy
        assert page.wait_for(lambda m: m["type"] == "refused")["kind"] == "bad_value"
        page.send({"type": "policy", "verb": "load", "policy": "dance_ppo"})
        answer = other.wait_for(lambda m: m["type"] == "answer" and m["to"] == "policy_load")  # every page sees it
        assert answer["success"] and answer["request"] == "policy load dance_ppo", answer
        assert answer["message"] == "stand-in: policy dance_ppo loaded"
        assert wait_until(lambda: other.states()[-1]["policy"]["status"]["policy"] == "dance_ppo", 5.0)
        assert other.states()[-1]["policy"]["status"]["phase"] == "loaded"
        page.send({"type": "policy", "verb": "engage"})  # refused by the node: its words, verbatim
        answer = other.wait_for(lambda m: m["type"] == "answer" and m["to"] == "policy_engage")
        assert not answer["success"] and answer["message"] == "engage refused: policy is loaded, not shadow; nothing sent"
        page.send({"type": "policy", "verb": "shadow"})  # a service this stand-in does not serve: tried, said why
        answer = page.wait_for(lambda m: m["type"] == "answer" and m["to"] == "policy_shadow")
        assert not answer["success"] and "/g1_mode_manager/policy/shadow is not available" in answer["message"]
        assert manager.called[called:] == ["policy/load dance_ppo", "policy/engage"]
    finally:
        other.close()
        page.close()
