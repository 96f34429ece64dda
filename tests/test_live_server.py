"""The live view's web server: loopback by default, a token off loopback, GET only, fixed files, SSE stream."""

from __future__ import annotations

import http.client
import json
import re
import socket

import pytest

from bootnav.errors import BootnavError
from bootnav.postproc.live.server import Hub, LiveServer, is_loopback
from tests.conftest import REPO

HELLO = {"mode": "live", "speed": 1.0, "no_motion_s": 30.0, "floor_height_m": 3.0, "floor_colors": ["#000"],
         "boots": [{"id": "0", "label": "a", "color": "#f00"}]}


@pytest.fixture
def server():
    srv = LiveServer(Hub(dict(HELLO)), "127.0.0.1", 0).start()
    yield srv
    srv.stop()


def _get(srv, path, method="GET", headers=None, host=None):
    port = srv.server_address[1]
    conn = http.client.HTTPConnection(host or "127.0.0.1", port, timeout=5)
    conn.request(method, path, headers=headers or {})
    resp = conn.getresponse()
    body = resp.read() if method != "HEAD" else b""
    conn.close()
    return resp.status, body, resp


def test_page_script_and_style_are_served_from_the_package(server):
    status, body, resp = _get(server, "/")
    assert status == 200 and resp.getheader("Content-Type").startswith("text/html")
    html = body.decode()
    assert 'src="static/live.js"' in html and 'href="static/live.css"' in html
    assert not re.search(r"https?://(?!www\.w3\.org/2000/svg)", html)  # nothing from the network (SVG namespace aside)
    for name, ctype in (("live.js", "text/javascript"), ("live.css", "text/css")):
        status, body, resp = _get(server, f"/static/{name}")
        assert status == 200 and resp.getheader("Content-Type").startswith(ctype) and len(body) > 500
        assert not re.search(rb"https?://(?!www\.w3\.org/2000/svg)", body) and b"cdn" not in body.lower()


@pytest.mark.parametrize("path", ["/static/../server.py", "/static/index.html", "/static/%2e%2e/cli.py",
                                  "/../../etc/passwd", "/server.py", "/static/"])
def test_nothing_but_the_fixed_files(server, path):
    assert _get(server, path)[0] == 404


@pytest.mark.parametrize("method", ["POST", "PUT", "DELETE", "PATCH", "HEAD", "OPTIONS"])
def test_read_only_get_only(server, method):
    status, _, resp = _get(server, "/", method=method)
    assert status == 405 and resp.getheader("Allow") == "GET"


def test_loopback_server_refuses_a_foreign_host_header(server):
    # DNS rebinding: a page of evil.example resolving to 127.0.0.1 must not read the view
    port = server.server_address[1]
    assert _get(server, "/state.json", headers={"Host": f"evil.example:{port}"})[0] == 403
    assert _get(server, "/state.json", headers={"Host": f"localhost:{port}"})[0] == 200


def test_off_loopback_requires_a_token():
    assert is_loopback("127.0.0.1") and is_loopback("::1") and is_loopback("localhost")
    assert not is_loopback("0.0.0.0") and not is_loopback("192.168.1.10")
    with pytest.raises(BootnavError, match="--token"):
        LiveServer(Hub(dict(HELLO)), "0.0.0.0", 0)


def test_every_request_must_carry_the_token():
    srv = LiveServer(Hub(dict(HELLO)), "0.0.0.0", 0, token="s3cret-token").start()
    try:
        assert srv.url.endswith("/?token=s3cret-token")
        for path in ("/", "/static/live.js", "/events", "/state.json"):
            assert _get(srv, path)[0] == 401
            assert _get(srv, path + "?token=wrong")[0] == 401
        status, body, _ = _get(srv, "/?token=s3cret-token")
        assert status == 200 and b"static/live.js?token=s3cret-token" in body  # the page passes it on
        assert _get(srv, "/static/live.css?token=s3cret-token")[0] == 200
        assert _get(srv, "/state.json", headers={"Authorization": "Bearer s3cret-token"})[0] == 200
        assert _get(srv, "/", method="POST", headers={"Authorization": "Bearer s3cret-token"})[0] == 405
    finally:
        srv.stop()


def _sse_events(sock_file, n):
    """The next ``n`` (event, data) pairs of an SSE stream."""
    out, event = [], None
    while len(out) < n:
        line = sock_file.readline().decode().rstrip("\n")
        if line.startswith("event: "):
            event = line[7:]
        elif line.startswith("data: "):
            out.append((event, json.loads(line[6:])))
    return out


def test_events_stream_sends_hello_then_strides_and_status(server):
    hub = server.hub
    hub.add_rows("0", [[0.0, 0.0, 0.0, 0.0, 0]])
    with socket.create_connection(("127.0.0.1", server.server_address[1]), timeout=5) as s:
        s.sendall(b"GET /events HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n")
        f = s.makefile("rb")
        assert f.readline().startswith(b"HTTP/1.1 200")
        while f.readline() not in (b"\r\n", b""):
            pass
        (e1, hello), (e2, first) = _sse_events(f, 2)
        assert e1 == "hello" and hello["boots"][0]["label"] == "a"
        assert e2 == "strides" and first == {"boot": "0", "rows": [[0.0, 0.0, 0.0, 0.0, 0]]}
        hub.add_rows("0", [[1.2, 1.3, 0.1, 0.0, 0]])
        hub.set_status({"0": {"floor": 0, "still_s": 0.0}})
        got = _sse_events(f, 2)
        assert ("strides", {"boot": "0", "rows": [[1.2, 1.3, 0.1, 0.0, 0]]}) in got  # only the new row
        assert any(e == "status" and d["boots"]["0"]["floor"] == 0 for e, d in got)


def test_cli_refuses_a_network_address_without_token(tmp_path, capsys):
    from bootnav.cli import main

    rec = str(REPO / "recordings" / "xio_ngimu_short_walk.h5")
    code = main(["live", "--replay", rec, "--host", "0.0.0.0", "--http-port", "0"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1 and len(err) == 1 and "--token" in err[0], err


def test_provisional_rows_are_replaced_not_appended(server):
    hub = server.hub
    with socket.create_connection(("127.0.0.1", server.server_address[1]), timeout=5) as s:
        s.sendall(b"GET /events HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n")
        f = s.makefile("rb")
        while f.readline() not in (b"\r\n", b""):
            pass
        assert _sse_events(f, 1)[0][0] == "hello"
        hub.set_provisional("0", [[2.0, 1.0, 0.0, 0.0, 0]])
        assert _sse_events(f, 1) == [("provisional", {"boot": "0", "rows": [[2.0, 1.0, 0.0, 0.0, 0]]})]
        version = hub.version
        hub.set_provisional("0", [[2.0, 1.0, 0.0, 0.0, 0]])  # unchanged: no message
        assert hub.version == version
        hub.add_rows("0", [[2.2, 1.1, 0.0, 0.0, 0]])  # the final stride, then the provisional one goes
        hub.set_provisional("0", [])
        got = _sse_events(f, 2)
        assert got[0] == ("strides", {"boot": "0", "rows": [[2.2, 1.1, 0.0, 0.0, 0]]})
        assert got[1] == ("provisional", {"boot": "0", "rows": []})
    assert hub.snapshot()["provisional"] == {"0": []}
