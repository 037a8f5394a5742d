"""Who may use the console: the token, and the Host and Origin a browser sends."""

from __future__ import annotations

import pytest

from g1_mode_manager.console.access import Access, is_loopback, load_token


@pytest.mark.parametrize("host", ["127.0.0.1", "127.5.6.7", "localhost", "::1", "[::1]", "LOCALHOST"])
def test_loopback_hosts(host: str) -> None:
    assert is_loopback(host)


@pytest.mark.parametrize("host", ["0.0.0.0", "::", "192.168.123.10", "example.com", "", "127.0.0.1.evil.com"])
def test_hosts_beyond_loopback(host: str) -> None:
    assert not is_loopback(host)


def test_a_bind_beyond_loopback_without_a_token_is_refused() -> None:
    with pytest.raises(ValueError, match="needs a token"):
        Access("0.0.0.0", "")
    Access("0.0.0.0", "s3cret-token")  # with one it starts


def test_the_token_is_required_on_every_request_once_set() -> None:
    access = Access("0.0.0.0", "s3cret-token")
    assert access.needs_token
    assert access.token_ok({"token": "s3cret-token"}, {})
    assert access.token_ok({}, {"Authorization": "Bearer s3cret-token"})
    assert not access.token_ok({}, {})
    assert not access.token_ok({"token": "s3cret-tokeN"}, {})
    assert not access.token_ok({"token": ""}, {})
    assert not access.token_ok({"token": "wrong"}, {"Authorization": "Bearer s3cret-token"})  # the query decides
    assert not access.token_ok({}, {"Authorization": "Basic s3cret-token"})


def test_loopback_without_a_token_needs_none_but_refuses_foreign_host_names() -> None:
    access = Access("127.0.0.1", "")
    assert not access.needs_token and access.token_ok({}, {})
    assert access.host_ok("127.0.0.1:8080") and access.host_ok("localhost:8080") and access.host_ok("[::1]:8080")
    assert not access.host_ok("rebound.example.com:8080")  # DNS rebinding to 127.0.0.1
    assert not access.host_ok(None)
    assert Access("127.0.0.1", "tok").host_ok("robot.example.com:8080")  # a token guards it instead


def test_a_websocket_from_another_origin_is_refused() -> None:
    assert Access.origin_ok("http://127.0.0.1:8080", "127.0.0.1:8080")
    assert not Access.origin_ok("http://evil.example.com", "127.0.0.1:8080")
    assert not Access.origin_ok("http://127.0.0.1:9999", "127.0.0.1:8080")
    assert not Access.origin_ok("http://127.0.0.1:8080", None)
    assert Access.origin_ok(None, "127.0.0.1:8080")  # not a browser: no page can make use of it


def test_token_file(tmp_path) -> None:
    path = tmp_path / "token"
    path.write_text("file-token\nignored\n")
    assert load_token("", str(path)) == "file-token"
    assert load_token(" param-token ", "") == "param-token"
    with pytest.raises(ValueError, match="not both"):
        load_token("a", str(path))
    path.write_text("\n")
    with pytest.raises(ValueError, match="empty"):
        load_token("", str(path))
