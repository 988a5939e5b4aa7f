"""Who may talk to ``parolkit gui``, against the real process over real HTTP and websocket
connections: a foreign ``Host`` is refused (400), a foreign ``Origin`` is refused (403) on
plain requests, the socket.io handshake and its websocket upgrade; bound beyond loopback the
commander refuses to start without a password, and with one every page and the socket
connection need a login.

The GUIs here use ``--connect`` to a UDP port nobody answers: the web server's rules do not
need a robot, and no controller process is started.
"""

from __future__ import annotations

import http.client
import os
import signal
import socket
import subprocess
import sys
import time
import urllib.parse
from pathlib import Path

import pytest
from tests.conftest import REPO_ROOT, free_tcp_port, free_udp_port, wait_until

from parolkit.client.launch import die_with_parent

PASSWORD = "correct horse battery"
SIO = "/_nicegui_ws/socket.io/?EIO=4&transport=polling"


class Gui:
    def __init__(self, tmp_path: Path, *args: str, config: str | None = None) -> None:
        self.port = free_tcp_port()
        self.log_path = tmp_path / f"gui-{self.port}.log"
        cmd = [sys.executable, "-m", "parolkit", "gui", "--connect", f"127.0.0.1:{free_udp_port()}",
               "--http-port", str(self.port), "--no-browser", "--programs-dir", str(tmp_path / "programs"), *args]
        if config is not None:
            cfg = tmp_path / f"gui-{self.port}.toml"
            cfg.write_text(config)
            cmd += ["--config", str(cfg)]
        env = dict(os.environ, PYTHONUNBUFFERED="1", PYTHONPATH=str(REPO_ROOT / "src"))
        env.pop("PYTEST_CURRENT_TEST", None)  # NiceGUI would switch to its own screen-test mode
        with open(self.log_path, "wb") as log:
            self.proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, env=env, cwd=tmp_path,
                                         preexec_fn=die_with_parent)

    def log(self) -> str:
        return self.log_path.read_text(errors="replace")

    def wait_serving(self) -> Gui:
        def up():
            assert self.proc.poll() is None, f"the GUI exited with {self.proc.returncode}:\n{self.log()}"
            try:
                return self.request("GET", "/login")[0] > 0
            except OSError:
                return False

        wait_until(up, 60, 0.2, what="the commander serving HTTP")
        return self

    def request(self, method: str, path: str, headers: dict[str, str] | None = None,
                body: str | None = None) -> tuple[int, dict[str, str], str]:
        """One request with exactly the given headers (Host defaults to 127.0.0.1:port)."""
        conn = http.client.HTTPConnection("127.0.0.1", self.port, timeout=10)
        try:
            hdrs = {"Host": f"127.0.0.1:{self.port}", **(headers or {})}
            conn.putrequest(method, path, skip_host=True, skip_accept_encoding=True)
            for k, v in hdrs.items():
                conn.putheader(k, v)
            data = body.encode() if body is not None else None
            if data is not None:
                conn.putheader("Content-Length", str(len(data)))
            conn.endheaders(data)
            r = conn.getresponse()
            return r.status, {k.lower(): v for k, v in r.getheaders()}, r.read().decode(errors="replace")
        finally:
            conn.close()

    def websocket(self, origin: str | None, cookie: str | None = None) -> str:
        """The status line (and headers) the server answers a socket.io websocket upgrade with."""
        lines = ["GET /_nicegui_ws/socket.io/?EIO=4&transport=websocket HTTP/1.1",
                 f"Host: 127.0.0.1:{self.port}", "Upgrade: websocket", "Connection: Upgrade",
                 "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==", "Sec-WebSocket-Version: 13"]
        if origin is not None:
            lines.append(f"Origin: {origin}")
        if cookie is not None:
            lines.append(f"Cookie: {cookie}")
        with socket.create_connection(("127.0.0.1", self.port), timeout=10) as s:
            s.sendall(("\r\n".join(lines) + "\r\n\r\n").encode())
            data = b""
            while b"\r\n\r\n" not in data:
                chunk = s.recv(4096)
                if not chunk:
                    break
                data += chunk
        return data.decode(errors="replace")

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(15)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(5)


@pytest.fixture(scope="module")
def loopback_gui(tmp_path_factory):
    gui = Gui(tmp_path_factory.mktemp("gui"))
    try:
        yield gui.wait_serving()
    finally:
        gui.stop()


def test_a_foreign_host_header_is_refused_and_the_own_names_are_served(loopback_gui):
    gui = loopback_gui
    for host in (f"127.0.0.1:{gui.port}", "localhost", f"[::1]:{gui.port}", "LOCALHOST."):
        assert gui.request("GET", "/", {"Host": host})[0] == 200, host
    # DNS rebinding: a page of evil.example whose name now points at 127.0.0.1
    for host in ("evil.example", f"evil.example:{gui.port}", "127.0.0.1.evil.example", ""):
        status, _, body = gui.request("GET", "/", {"Host": host})
        assert status == 400, (host, status)
        assert "is not one of this commander's names" in body and "gui.allowed_hosts" in body
    # the socket connection too, and a websocket upgrade with a foreign Host
    assert gui.request("GET", SIO, {"Host": "evil.example"})[0] == 400


def test_a_request_without_a_host_header_is_refused(loopback_gui):
    with socket.create_connection(("127.0.0.1", loopback_gui.port), timeout=10) as s:
        s.sendall(b"GET / HTTP/1.0\r\n\r\n")
        reply = s.recv(4096).decode(errors="replace")
    assert reply.startswith("HTTP/1.1 400"), reply[:200]


def test_a_foreign_origin_is_refused_on_requests_and_on_the_socket_connection(loopback_gui):
    gui = loopback_gui
    own = f"http://127.0.0.1:{gui.port}"
    status, headers, body = gui.request("GET", SIO, {"Origin": own})
    assert status == 200 and '"sid"' in body
    assert headers.get("access-control-allow-origin") == own  # socket.io reflects only an allowed origin
    for origin in ("http://evil.example", f"http://evil.example:{gui.port}", "null", "http://127.0.0.1.evil.example"):
        status, headers, body = gui.request("GET", SIO, {"Origin": origin})
        assert status == 403, (origin, status)
        assert "access-control-allow-origin" not in headers
        assert "is not one of this commander's names" in body
    assert gui.request("GET", "/", {"Origin": "http://evil.example"})[0] == 403
    # the websocket upgrade: refused before any socket.io traffic, accepted from the page's own origin
    assert gui.websocket("http://evil.example").startswith("HTTP/1.1 403")
    assert gui.websocket(own).startswith("HTTP/1.1 101")
    assert gui.websocket(None).startswith("HTTP/1.1 101")  # a non-browser client sends none


def test_a_post_without_an_origin_is_refused(loopback_gui):
    status, _, body = loopback_gui.request("POST", SIO, {"Content-Type": "text/plain"}, "40")
    assert status == 403 and "without an Origin header" in body


@pytest.mark.parametrize("host", ["0.0.0.0", "::"])
def test_bound_beyond_loopback_the_commander_refuses_to_start_without_a_password(tmp_path, host):
    gui = Gui(tmp_path, "--host", host)
    try:
        assert gui.proc.wait(60) == 2
    finally:
        gui.stop()
    log = gui.log()
    assert f"refusing to bind {host}" in log and "gui.password" in log
    assert "parolkit commander on" not in log  # never served


def test_bound_beyond_loopback_every_page_and_the_socket_connection_need_the_login(tmp_path):
    gui = Gui(tmp_path, "--host", "0.0.0.0", config=f'[gui]\npassword = "{PASSWORD}"\n').wait_serving()
    try:
        own = {"Origin": f"http://127.0.0.1:{gui.port}"}
        # not logged in: the page redirects to the login form, the rest is 401
        status, headers, _ = gui.request("GET", "/")
        assert status == 303 and headers["location"] == "/login?next=%2F"
        assert gui.request("GET", SIO, own)[0] == 401
        assert gui.websocket(own["Origin"]).startswith("HTTP/1.1 401")
        status, _, page = gui.request("GET", "/login?next=/")
        assert status == 200 and 'type="password"' in page
        # a wrong password: the form again with the reason, no cookie
        form = {"Content-Type": "application/x-www-form-urlencoded", **own}
        status, headers, page = gui.request("POST", "/login", form, "password=guess&next=%2F")
        assert status == 401 and "Wrong password." in page and "set-cookie" not in headers
        # a login form posted from another site is refused before the password is looked at
        evil = {**form, "Origin": "http://evil.example"}
        body = urllib.parse.urlencode({"password": PASSWORD, "next": "/"})
        assert gui.request("POST", "/login", evil, body)[0] == 403
        # the right password: a session cookie (HttpOnly, SameSite=Strict) and back to the page
        next_body = urllib.parse.urlencode({"password": PASSWORD, "next": "//evil.example/"})
        status, headers, _ = gui.request("POST", "/login", form, next_body)
        assert status == 303 and headers["location"] == "/"  # never redirected to another site
        cookie = headers["set-cookie"].split(";", 1)[0]
        assert cookie.startswith("parolkit_session=") and "HttpOnly" in headers["set-cookie"]
        assert "SameSite=Strict" in headers["set-cookie"]
        with_cookie = {"Cookie": cookie}
        assert gui.request("GET", "/", with_cookie)[0] == 200
        status, _, body = gui.request("GET", SIO, {**with_cookie, **own})
        assert status == 200 and '"sid"' in body
        assert gui.websocket(own["Origin"], cookie).startswith("HTTP/1.1 101")
        assert gui.request("GET", "/", {"Cookie": "parolkit_session=forged"})[0] == 303
        # log out: the cookie no longer opens anything
        assert gui.request("GET", "/logout", with_cookie)[0] == 303
        assert gui.request("GET", "/", with_cookie)[0] == 303
        # the Host rule still applies behind the login
        assert gui.request("GET", "/login", {"Host": "evil.example"})[0] == 400
    finally:
        gui.stop()
    assert PASSWORD not in gui.log()


def test_repeated_wrong_passwords_are_refused_for_a_while(tmp_path):
    gui = Gui(tmp_path, config=f'[gui]\npassword = "{PASSWORD}"\n').wait_serving()
    try:
        form = {"Content-Type": "application/x-www-form-urlencoded", "Origin": f"http://127.0.0.1:{gui.port}"}
        t0 = time.monotonic()
        for _ in range(5):
            assert gui.request("POST", "/login", form, "password=guess")[0] == 401
        assert time.monotonic() - t0 >= 5 * 0.5  # each failure is answered late
        status, _, page = gui.request("POST", "/login", form, urllib.parse.urlencode({"password": PASSWORD}))
        assert status == 429 and "Too many failed logins" in page  # even the right one, for now
    finally:
        gui.stop()
