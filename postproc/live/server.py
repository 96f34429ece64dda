"""The live view's web server: the page, its script and style, and a Server-Sent Events stream.

Standard library only (``http.server.ThreadingHTTPServer``, one thread per open page): the view must run
offline on an incident laptop with nothing to install, and its load is a few messages per second per boot,
far below what a thread per client serves. SSE (``text/event-stream``) pushes strides and status one way,
which is all the page needs; a browser's ``EventSource`` reconnects by itself after a dropped link, and the
server then sends the whole state again.

Security: bound to the loopback address by default; any other address needs an access token, which every
request must carry (``?token=`` or ``Authorization: Bearer``); compared in constant time. On loopback the
``Host`` header must name the loopback host too (a web page elsewhere cannot reach the view through DNS
rebinding). Read-only: GET only (any other method gets 405), a fixed set of files from ``static/`` and two
generated resources, no code path that runs anything the client sends.
"""

from __future__ import annotations

import hmac
import ipaddress
import json
import secrets
import socket
import threading
import time
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from urllib.parse import parse_qs, urlsplit

from bootnav.core.jsonio import to_jsonable
from bootnav.errors import BootnavError

STATIC_DIR = Path(__file__).with_name("static")
STATIC_TYPES = {".js": "text/javascript; charset=utf-8", ".css": "text/css; charset=utf-8"}
#: SSE comment sent when nothing else was, so a closed page is noticed and its thread ends
HEARTBEAT_S = 2.0


class Hub:
    """What the page shows, shared between the feeding thread and the page threads.

    Per boot the stride rows (``[t_s, x_m, y_m, z_m, floor]``, the start footprint first) only grow; the
    provisional rows (same columns, after the final ones) and the status are replaced. Every change bumps
    ``version`` and wakes the waiting page threads.

    Parameters
    ----------
    hello : dict
        The first message of every stream: mode, boots (``id``, ``label``, ``color``), alarm time, palette.
    """

    def __init__(self, hello: dict):
        self.hello = hello
        self._rows: dict[str, list] = {b["id"]: [] for b in hello["boots"]}
        self._status: dict[str, dict] = {}
        self._prov: dict[str, tuple[int, list]] = {b["id"]: (0, []) for b in hello["boots"]}  # (version, rows)
        self._cond = threading.Condition()
        self.version = 0
        self.closed = False

    def add_rows(self, boot_id: str, rows: list) -> None:
        if not rows:
            return
        with self._cond:
            self._rows[boot_id].extend(rows)
            self.version += 1
            self._cond.notify_all()

    def set_provisional(self, boot_id: str, rows: list) -> None:
        """Replace the boot's provisional rows (no change, no message)."""
        with self._cond:
            version, old = self._prov[boot_id]
            if rows == old:
                return
            self._prov[boot_id] = (version + 1, list(rows))
            self.version += 1
            self._cond.notify_all()

    def set_status(self, status: dict) -> None:
        with self._cond:
            self._status.update(status)
            self.version += 1
            self._cond.notify_all()

    def close(self) -> None:
        with self._cond:
            self.closed = True
            self._cond.notify_all()

    def wait(self, seen: int, timeout: float) -> int:
        """Block until ``version`` differs from ``seen`` (or the timeout, or closing); return the version."""
        with self._cond:
            self._cond.wait_for(lambda: self.version != seen or self.closed, timeout)
            return self.version

    def since(self, cursors: dict[str, int]) -> tuple[dict[str, list], dict[str, list], dict]:
        """New rows per boot after ``cursors`` (advanced in place), the provisional rows of the boots whose
        provisional rows changed since then, and a copy of the status."""
        with self._cond:
            new, prov = {}, {}
            for boot_id, rows in self._rows.items():
                k = cursors.get(boot_id, 0)
                if len(rows) > k:
                    new[boot_id] = rows[k:]
                    cursors[boot_id] = len(rows)
                version, p_rows = self._prov[boot_id]
                if cursors.get("provisional:" + boot_id, 0) != version:
                    prov[boot_id] = list(p_rows)
                    cursors["provisional:" + boot_id] = version
            return new, prov, dict(self._status)

    def snapshot(self) -> dict:
        with self._cond:
            return {"hello": self.hello, "rows": {k: list(v) for k, v in self._rows.items()},
                    "provisional": {k: list(v[1]) for k, v in self._prov.items()}, "status": dict(self._status)}


def is_loopback(host: str) -> bool:
    """Whether ``host`` (an address or ``localhost``) is the loopback interface."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


class _Handler(BaseHTTPRequestHandler):
    server: "LiveServer"
    protocol_version = "HTTP/1.1"

    def log_message(self, format, *args):  # noqa: A002 - the page polls; no access log on the console
        pass

    def _refuse(self, status: HTTPStatus, text: str, headers: dict | None = None) -> None:
        body = (text + "\n").encode()
        self.send_response(status)
        for k, v in (headers or {}).items():
            self.send_header(k, v)
        self.send_header("Content-Type", "text/plain; charset=utf-8")
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        if self.command != "HEAD":
            self.wfile.write(body)

    def _not_allowed(self) -> None:
        self._refuse(HTTPStatus.METHOD_NOT_ALLOWED, "read-only view: GET only", {"Allow": "GET"})

    do_POST = do_PUT = do_DELETE = do_PATCH = do_HEAD = do_OPTIONS = do_TRACE = do_CONNECT = _not_allowed

    def _allowed(self, query: dict) -> bool:
        srv = self.server
        if srv.loopback_only:
            host = (self.headers.get("Host") or "").rsplit(":", 1)[0]
            if not is_loopback(host):
                self._refuse(HTTPStatus.FORBIDDEN, "Host header is not the loopback address")
                return False
        if srv.token is None:
            return True
        given = (query.get("token") or [""])[0]
        auth = self.headers.get("Authorization") or ""
        if auth.startswith("Bearer "):
            given = given or auth[7:]
        if hmac.compare_digest(given.encode(), srv.token.encode()):
            return True
        self._refuse(HTTPStatus.UNAUTHORIZED, "access token missing or wrong: open the URL bootnav live printed")
        return False

    def do_GET(self):  # noqa: N802 - http.server's naming
        url = urlsplit(self.path)
        query = parse_qs(url.query)
        if not self._allowed(query):
            return
        path = url.path
        if path in ("/", "/index.html"):
            qs = f"?token={self.server.token}" if self.server.token else ""
            text = (STATIC_DIR / "index.html").read_text().replace("{{QUERY}}", qs)
            self._send(text.encode(), "text/html; charset=utf-8")
        elif path.startswith("/static/") and path[len("/static/"):] in self.server.static_files:
            name = path[len("/static/"):]
            self._send((STATIC_DIR / name).read_bytes(), STATIC_TYPES[Path(name).suffix])
        elif path == "/state.json":
            self._send(_json(self.server.hub.snapshot()).encode(), "application/json")
        elif path == "/events":
            self._events()
        else:
            self._refuse(HTTPStatus.NOT_FOUND, f"{path}: not here (the view is at /)")

    def _send(self, body: bytes, ctype: str) -> None:
        self.send_response(HTTPStatus.OK)
        self.send_header("Content-Type", ctype)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Cache-Control", "no-store")
        self.end_headers()
        self.wfile.write(body)

    def _events(self) -> None:
        hub = self.server.hub
        self.send_response(HTTPStatus.OK)
        self.send_header("Content-Type", "text/event-stream")
        self.send_header("Cache-Control", "no-store")
        self.send_header("Connection", "close")
        self.end_headers()
        self.close_connection = True
        cursors: dict[str, int] = {}
        seen, last_sent = -1, time.monotonic()
        try:
            self._sse("hello", hub.hello)
            while not self.server.stopping:
                version = hub.wait(seen, timeout=0.5)
                if version != seen:
                    seen = version
                    new, prov, status = hub.since(cursors)
                    for boot_id, rows in new.items():  # the final strides before the provisional ones they replace
                        self._sse("strides", {"boot": boot_id, "rows": rows})
                    for boot_id, rows in prov.items():
                        self._sse("provisional", {"boot": boot_id, "rows": rows})
                    if status:
                        self._sse("status", {"boots": status})
                    last_sent = time.monotonic()
                elif time.monotonic() - last_sent >= HEARTBEAT_S:
                    self.wfile.write(b": ping\n\n")
                    self.wfile.flush()
                    last_sent = time.monotonic()
        except (BrokenPipeError, ConnectionResetError, TimeoutError):
            pass  # the page was closed

    def _sse(self, event: str, data: dict) -> None:
        self.wfile.write(f"event: {event}\ndata: {_json(data)}\n\n".encode())
        self.wfile.flush()


def _json(data) -> str:
    """Strict JSON (a NaN becomes null: a browser's JSON.parse rejects NaN)."""
    return json.dumps(to_jsonable(data, max_array_size=None), separators=(",", ":"), allow_nan=False)


class LiveServer(ThreadingHTTPServer):
    """The HTTP server of one live session (``serve_forever`` in a thread; ``stop`` ends it and its streams).

    Parameters
    ----------
    hub : Hub
    host : str
        Address to bind; not a loopback address only with ``token``.
    port : int
        0 picks a free port (``url`` says which).
    token : str or None
        Access token every request must carry; required off loopback.
    """

    daemon_threads = True
    allow_reuse_address = True

    def __init__(self, hub: Hub, host: str = "127.0.0.1", port: int = 0, token: str | None = None):
        if not is_loopback(host) and not token:
            raise BootnavError(f"--host {host}: not the loopback address; the view would be open to the network, "
                               "so give --token T (or --token auto) so that every request must carry it")
        self.hub = hub
        self.token = token
        self.loopback_only = is_loopback(host)
        self.stopping = False
        self.static_files = frozenset(p.name for p in STATIC_DIR.iterdir() if p.suffix in STATIC_TYPES)
        if ":" in host:
            self.address_family = socket.AF_INET6
        try:
            super().__init__((host, port), _Handler)
        except OSError as exc:
            raise BootnavError(f"cannot serve on {host}:{port}: {exc.strerror or exc}; choose another --http-port "
                               "or --host") from exc
        self._thread: threading.Thread | None = None

    @property
    def url(self) -> str:
        host, port = self.server_address[:2]
        host = f"[{host}]" if ":" in host else host
        return f"http://{host}:{port}/" + (f"?token={self.token}" if self.token else "")

    def start(self) -> "LiveServer":
        self._thread = threading.Thread(target=self.serve_forever, kwargs={"poll_interval": 0.2},
                                        name="bootnav-live-http", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        self.stopping = True
        self.hub.close()
        self.shutdown()
        self.server_close()


def new_token() -> str:
    """A random URL-safe access token (128 bits)."""
    return secrets.token_urlsafe(16)
