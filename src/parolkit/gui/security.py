"""Who may talk to the commander's web server: the ``Host`` / ``Origin`` allow-list and the login.

A pure ASGI middleware (:class:`SecurityMiddleware`, no NiceGUI import) in front of every
HTTP request and websocket of the commander, the socket.io connection included:

* **Host**: the name in the ``Host`` header must be in the allow-list (:class:`AccessPolicy`:
  localhost, 127.0.0.1, ::1, the bound address, and ``gui.allowed_hosts``; bound to every
  interface, also the machine's own names and addresses).  Anything else gets ``400``: a web
  page whose DNS name was re-pointed at this machine (DNS rebinding) cannot reach the commander.
* **Origin**: a request that carries an ``Origin`` header (a browser's websocket, socket.io
  and form posts, any cross-site fetch) must come from an allowed host, else ``403``.  A
  request without one (curl, scripts) is allowed for GET and HEAD only.
* **Login** (when a password is configured; ``parolkit gui`` requires one beyond loopback): a
  plain login form at ``/login``; the password is compared in constant time; a right one gets
  a random session cookie (HttpOnly, SameSite=Strict) kept in memory by the server; every other
  path needs that cookie (pages are redirected to the login form, the rest gets ``401``).
  Failed logins are slowed down and limited per client address.  The password is never
  logged or echoed.
* **A class** (``gui.teacher_password``, :mod:`parolkit.gui.classroom`): the login form asks a
  student's name (and the class password, ``gui.password``, if one is set) or the teacher's
  password; each session is a member of the class (the teacher or the student of that name), and
  a session whose member left (logged out, replaced) is no longer valid.
"""

from __future__ import annotations

import asyncio
import hashlib
import hmac
import html
import ipaddress
import secrets
import socket
import time
import urllib.parse
from collections import deque
from collections.abc import Awaitable, Callable, Iterable, MutableMapping
from dataclasses import dataclass, field
from typing import Any

from parolkit.errors import ParolkitError
from parolkit.gui.classroom import Classroom, ClassroomError, Member

__all__ = [
    "AccessPolicy",
    "LoginGate",
    "SecurityMiddleware",
    "WrongPassword",
    "session_key",
    "host_name",
    "is_loopback_bind",
    "machine_names",
    "origin_host",
    "SESSION_COOKIE",
]

Scope = MutableMapping[str, Any]
Message = MutableMapping[str, Any]
Receive = Callable[[], Awaitable[Message]]
Send = Callable[[Message], Awaitable[None]]
ASGIApp = Callable[[Scope, Receive, Send], Awaitable[None]]

#: the session cookie's name
SESSION_COOKIE = "parolkit_session"
#: a session lasts this long after login, s
SESSION_LIFETIME_S = 12 * 3600.0
#: failed logins allowed per client address within :data:`FAILURE_WINDOW_S`
MAX_FAILURES = 5
FAILURE_WINDOW_S = 60.0
#: a failed login is answered after this delay, s (slows guessing)
FAILURE_DELAY_S = 0.5
#: largest login form body read, bytes
MAX_FORM_BYTES = 4096

LOOPBACK_NAMES = ("localhost", "127.0.0.1", "::1")
_WILDCARDS = ("0.0.0.0", "::", "")


def is_loopback_bind(host: str) -> bool:
    """True when binding ``host`` serves this machine only (localhost, 127.0.0.0/8, ::1)."""
    if host.lower() == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        try:
            return ipaddress.ip_address(socket.gethostbyname(host)).is_loopback
        except (OSError, ValueError):
            return False


def host_name(header: str | None) -> str | None:
    """The name in a ``Host`` header (``name``, ``name:port``, ``[v6]``, ``[v6]:port``),
    lower case without a trailing dot; None when malformed."""
    if header is None:
        return None
    h = header.strip().lower()
    if not h or any(c in h for c in " \t/\\@?#"):
        return None
    if h.startswith("["):
        end = h.find("]")
        if end < 0:
            return None
        name, rest = h[1:end], h[end + 1:]
        if rest and not (rest.startswith(":") and rest[1:].isdigit()):
            return None
        try:
            ipaddress.IPv6Address(name)
        except ValueError:
            return None
        return name
    name, sep, port = h.partition(":")
    if sep and not port.isdigit():
        return None
    name = name.rstrip(".")
    return name or None


def origin_host(origin: str) -> str | None:
    """The host of an ``Origin`` header (``http(s)://name[:port]``); None for ``null`` or
    anything that is not an http(s) origin."""
    try:
        parts = urllib.parse.urlsplit(origin.strip())
    except ValueError:
        return None
    if parts.scheme not in ("http", "https") or not parts.netloc or parts.path not in ("", "/") \
            or parts.query or parts.fragment or "@" in parts.netloc:
        return None
    return host_name(parts.netloc)


def machine_names() -> set[str]:
    """This machine's host name, fully qualified name and their addresses, and the address of
    its default route: the names a browser on the network uses to reach it."""
    names: set[str] = set()
    for name in (socket.gethostname(), socket.getfqdn()):
        if name:
            names.add(name.lower())
            try:
                names.update(str(info[4][0]).lower() for info in socket.getaddrinfo(name, None))
            except OSError:
                pass
    try:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            s.connect(("192.0.2.1", 9))  # no datagram is sent: this only picks the route
            names.add(str(s.getsockname()[0]))
    except OSError:
        pass
    return {n.split("%", 1)[0] for n in names}


@dataclass(frozen=True)
class AccessPolicy:
    """The allow-list of host names (lower case, IPv6 without brackets)."""

    allowed: frozenset[str]

    @classmethod
    def for_bind(cls, bind_host: str, extra: Iterable[str] = (),
                 machine: Callable[[], set[str]] = machine_names) -> AccessPolicy:
        """Loopback names, the bound address (or, bound to every interface, the machine's
        own names and addresses: :func:`machine_names`) and ``extra`` (gui.allowed_hosts)."""
        names = set(LOOPBACK_NAMES)
        bind = bind_host.strip().lower().strip("[]")
        if bind in _WILDCARDS:
            names |= machine()
        else:
            names.add(bind)
        names.update(h.strip().lower().strip("[]").rstrip(".") for h in extra)
        return cls(frozenset(names))

    def host_allowed(self, header: str | None) -> bool:
        name = host_name(header)
        return name is not None and name in self.allowed

    def origin_allowed(self, origin: str | None, environ: object = None) -> bool:
        """True for an http(s) origin on an allowed host (any port: an SSH tunnel or a reverse
        proxy may change it).  ``environ`` is ignored: the signature of engineio's
        ``cors_allowed_origins`` callable."""
        if origin is None:
            return False
        name = origin_host(origin)
        return name is not None and name in self.allowed


def session_key(token: str) -> str:
    """What the server keeps of a session token (its SHA-256): the key of the session and of
    its member of a class."""
    return hashlib.sha256(token.encode("utf-8", "replace")).hexdigest()


def _same(given: str, password: str) -> bool:
    """Constant-time comparison of a typed password with a configured one."""
    return hmac.compare_digest(given.encode("utf-8", "replace"), password.encode("utf-8"))


class WrongPassword(ParolkitError):
    """A login with a password that is not the (teacher's or class) password."""


@dataclass
class LoginGate:
    """The password and the sessions it opened (in memory: a restart logs everyone out).
    With ``classroom`` (a class, gui.teacher_password) ``password`` is the class password
    students give with their name (None: a name is enough)."""

    password: str | None
    lifetime_s: float = SESSION_LIFETIME_S
    teacher_password: str | None = None
    classroom: Classroom | None = None
    _sessions: dict[str, float] = field(default_factory=dict, repr=False)
    _failures: dict[str, deque[float]] = field(default_factory=dict, repr=False)

    def __post_init__(self) -> None:
        if (self.classroom is None) != (self.teacher_password is None):
            raise ValueError("LoginGate: a class needs both the classroom and the teacher's password")
        if self.classroom is None and self.password is None:
            raise ValueError("LoginGate: a login without a class needs the password")

    def __repr__(self) -> str:  # never show the password
        return f"LoginGate(sessions={len(self._sessions)})"

    @staticmethod
    def _key(token: str) -> str:
        return session_key(token)

    def check_password(self, given: str) -> bool:
        """Constant-time comparison with the configured password (False when there is none)."""
        return self.password is not None and _same(given, self.password)

    def log_in(self, given: str, name: str = "", now: float | None = None) -> str:
        """A new session for a login form's password ``given`` (and, in a class, ``name``);
        raises WrongPassword (counted as a failure by the caller) or, in a class, ClassroomError
        for a name refused (the message says why)."""
        room = self.classroom
        if room is None:
            if not self.check_password(given):
                raise WrongPassword()
            return self.open_session(now)
        now = time.monotonic() if now is None else now
        if self.teacher_password is not None and _same(given, self.teacher_password):
            token = self.open_session(now)
            room.join_teacher(self._key(token), now)
            return token
        class_password_wrong = not self.check_password(given) if self.password is not None else bool(given)
        if class_password_wrong:  # (no class password: a student gives none; a wrong teacher's one)
            raise WrongPassword()
        if not name.strip():
            raise ClassroomError("type your name (students), or the teacher's password (the teacher)")
        token = self.open_session(now)
        try:
            room.join_student(self._key(token), name, now)
        except ClassroomError:
            self._sessions.pop(self._key(token), None)
            raise
        return token

    def member(self, token: str | None) -> Member | None:
        """The class member of a valid session (None: no class, or no such session)."""
        if self.classroom is None or not self.valid(token):
            return None
        assert token is not None
        return self.classroom.member(self._key(token))

    def open_session(self, now: float | None = None) -> str:
        """A new random session token (256 bits), valid for ``lifetime_s``."""
        now = time.monotonic() if now is None else now
        self._sessions = {k: t for k, t in self._sessions.items() if t > now}
        token = secrets.token_urlsafe(32)
        self._sessions[self._key(token)] = now + self.lifetime_s
        return token

    def valid(self, token: str | None, now: float | None = None) -> bool:
        if not token:
            return False
        key = self._key(token)
        expiry = self._sessions.get(key)
        if expiry is None or expiry <= (time.monotonic() if now is None else now):
            return False
        return self.classroom is None or self.classroom.member(key) is not None

    def close_session(self, token: str | None, now: float | None = None) -> None:
        if token:
            key = self._key(token)
            self._sessions.pop(key, None)
            if self.classroom is not None:
                self.classroom.leave(key, time.monotonic() if now is None else now)

    def blocked_for(self, client: str, now: float | None = None) -> float:
        """Seconds until ``client`` may try again (0: now)."""
        now = time.monotonic() if now is None else now
        fails = self._failures.get(client)
        if fails is None:
            return 0.0
        while fails and fails[0] <= now - FAILURE_WINDOW_S:
            fails.popleft()
        if len(fails) < MAX_FAILURES:
            return 0.0
        return fails[0] + FAILURE_WINDOW_S - now

    def record_failure(self, client: str, now: float | None = None) -> None:
        self._failures.setdefault(client, deque()).append(time.monotonic() if now is None else now)


LOGIN_PAGE = """<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>parolkit commander: log in</title>
<meta name="viewport" content="width=device-width, initial-scale=1">
<style>
body {{ background: #0b1220; color: #e6edf7; font-family: system-ui, sans-serif; display: flex;
       justify-content: center; align-items: center; min-height: 90vh; }}
form {{ background: #111a2e; border: 1px solid #1e2a44; border-radius: 12px; padding: 28px; width: 320px; }}
h1 {{ font-size: 18px; margin: 0 0 16px; }}
input {{ width: 100%; box-sizing: border-box; padding: 8px; margin: 6px 0 14px; border-radius: 6px;
        border: 1px solid #334155; background: #0b1220; color: #e6edf7; }}
button {{ background: #2563eb; color: white; border: 0; border-radius: 6px; padding: 8px 18px; }}
.err {{ color: #fca5a5; font-size: 14px; margin-bottom: 10px; }}
</style></head>
<body><form method="post" action="/login">
<h1>parolkit commander</h1>
{message}
{fields}
<input type="hidden" name="next" value="{next}">
<button type="submit" data-testid="login-submit">Log in</button>
</form></body></html>
"""


PASSWORD_FIELD = """<label for="password">{label}</label>
<input id="password" name="password" type="password" autocomplete="current-password"{focus}
       data-testid="login-password">"""
#: a class: a student's name first
NAME_FIELD = """<label for="name">Your name (students)</label>
<input id="name" name="name" autocomplete="username" autofocus maxlength="100" data-testid="login-name">"""


def _form_fields(gate: LoginGate) -> str:
    if gate.classroom is None:
        return PASSWORD_FIELD.format(label="Password", focus=" autofocus")
    label = ("Password: the teacher's, or the class password (students)" if gate.password is not None
             else "Teacher's password (students leave it empty)")
    return NAME_FIELD + "\n" + PASSWORD_FIELD.format(label=label, focus="")


def _headers(scope: Scope) -> dict[str, list[str]]:
    out: dict[str, list[str]] = {}
    for key, value in scope.get("headers", ()):
        out.setdefault(key.decode("latin-1").lower(), []).append(value.decode("latin-1"))
    return out


def _cookie(headers: dict[str, list[str]], name: str) -> str | None:
    for line in headers.get("cookie", ()):
        for part in line.split(";"):
            key, sep, value = part.strip().partition("=")
            if sep and key == name:
                return value
    return None


def _safe_next(value: str) -> str:
    """A local path to return to after login (never another site)."""
    if not value.startswith("/") or value.startswith("//") or "\\" in value or any(ord(c) < 32 for c in value):
        return "/"
    return value


class SecurityMiddleware:
    """The checks of this module in front of ``app`` (Host, then Origin, then login)."""

    def __init__(self, app: ASGIApp, policy: AccessPolicy, login: LoginGate | None = None) -> None:
        self.app = app
        self.policy = policy
        self.login = login

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        kind = scope["type"]
        if kind not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        headers = _headers(scope)
        hosts = headers.get("host", [])
        if len(hosts) != 1 or not self.policy.host_allowed(hosts[0]):
            shown = hosts[0] if len(hosts) == 1 else f"{len(hosts)} Host headers"
            await _deny(scope, receive, send, 400,
                        f"Host {shown[:100]!r} is not one of this commander's names: refused "
                        "(add the name to gui.allowed_hosts in the config to use it)")
            return
        origins = headers.get("origin", [])
        method = scope.get("method", "GET") if kind == "http" else "GET"
        if origins:
            if len(origins) != 1 or not self.policy.origin_allowed(origins[0]):
                await _deny(scope, receive, send, 403,
                            f"Origin {origins[0][:100]!r} is not one of this commander's names: refused "
                            "(a page of another site may not use the commander)")
                return
        elif method not in ("GET", "HEAD"):
            await _deny(scope, receive, send, 403, f"a {method} request without an Origin header is refused")
            return
        if self.login is not None:
            path = scope.get("path", "/")
            if kind == "http" and path == "/login":
                await self._login(scope, receive, send, method)
                return
            token = _cookie(headers, SESSION_COOKIE)
            if kind == "http" and path == "/logout":
                self.login.close_session(token)
                await _respond(send, 303, b"", [(b"location", b"/login"), _clear_cookie()])
                return
            if not self.login.valid(token):
                if kind == "http" and method == "GET" and not path.startswith("/_nicegui"):
                    target = path + ("?" + scope["query_string"].decode("latin-1") if scope.get("query_string") else "")
                    location = "/login?" + urllib.parse.urlencode({"next": target})
                    await _respond(send, 303, b"", [(b"location", location.encode("latin-1"))])
                else:
                    await _deny(scope, receive, send, 401, "log in first (at /login)")
                return
        await self.app(scope, receive, send)

    async def _login(self, scope: Scope, receive: Receive, send: Send, method: str) -> None:
        assert self.login is not None
        query = urllib.parse.parse_qs(scope.get("query_string", b"").decode("latin-1"))
        if method in ("GET", "HEAD"):
            await _login_page(send, 200, "", _safe_next(query.get("next", ["/"])[0]), self.login)
            return
        if method != "POST":
            await _respond(send, 405, b"use GET or POST", [(b"allow", b"GET, POST")])
            return
        client = str((scope.get("client") or ("unknown", 0))[0])
        wait = self.login.blocked_for(client)
        if wait > 0:
            await _login_page(send, 429, f"Too many failed logins: try again in {wait:.0f} s.", "/", self.login)
            return
        body = await _read_body(receive, MAX_FORM_BYTES)
        if body is None:
            await _respond(send, 413, f"the login form is limited to {MAX_FORM_BYTES} bytes".encode(), [])
            return
        form = urllib.parse.parse_qs(body.decode("utf-8", "replace"), keep_blank_values=True)
        given = form.get("password", [""])[0]
        target = _safe_next(form.get("next", ["/"])[0])
        try:
            token = self.login.log_in(given, form.get("name", [""])[0])
        except WrongPassword:
            self.login.record_failure(client)
            await asyncio.sleep(FAILURE_DELAY_S)
            await _login_page(send, 401, "Wrong password.", target, self.login)
            return
        except ClassroomError as exc:  # a student's name refused (the message names the rule)
            await _login_page(send, 400, str(exc), target, self.login)
            return
        cookie = (f"{SESSION_COOKIE}={token}; Path=/; HttpOnly; SameSite=Strict; "
                  f"Max-Age={int(self.login.lifetime_s)}")
        await _respond(send, 303, b"", [(b"location", target.encode("latin-1")),
                                        (b"set-cookie", cookie.encode("latin-1"))])


def _clear_cookie() -> tuple[bytes, bytes]:
    return b"set-cookie", f"{SESSION_COOKIE}=; Path=/; HttpOnly; SameSite=Strict; Max-Age=0".encode()


async def _read_body(receive: Receive, limit: int) -> bytes | None:
    """The request body, or None when it is longer than ``limit`` bytes."""
    chunks: list[bytes] = []
    size = 0
    while True:
        message = await receive()
        if message["type"] != "http.request":
            return b"".join(chunks)
        chunk = message.get("body", b"")
        size += len(chunk)
        if size > limit:
            return None
        chunks.append(chunk)
        if not message.get("more_body", False):
            return b"".join(chunks)


async def _login_page(send: Send, status: int, message: str, target: str, gate: LoginGate) -> None:
    msg = f'<div class="err" data-testid="login-error">{html.escape(message)}</div>' if message else ""
    page = LOGIN_PAGE.format(message=msg, fields=_form_fields(gate), next=html.escape(target, quote=True))
    await _respond(send, status, page.encode("utf-8"), [(b"content-type", b"text/html; charset=utf-8"),
                                                        (b"cache-control", b"no-store")])


async def _respond(send: Send, status: int, body: bytes,
                   headers: list[tuple[bytes, bytes]]) -> None:
    if not any(k == b"content-type" for k, _ in headers):
        headers = [*headers, (b"content-type", b"text/plain; charset=utf-8")]
    await send({"type": "http.response.start", "status": status,
                "headers": [*headers, (b"content-length", str(len(body)).encode())]})
    await send({"type": "http.response.body", "body": body})


async def _deny(scope: Scope, receive: Receive, send: Send, status: int, text: str) -> None:
    """Refuse an HTTP request or a websocket handshake with ``status`` and ``text``."""
    body = (text + "\n").encode("utf-8")
    if scope["type"] == "http":
        await _respond(send, status, body, [])
        return
    message = await receive()  # websocket.connect
    if message["type"] != "websocket.connect":
        return
    if "websocket.http.response" in scope.get("extensions", {}):
        await send({"type": "websocket.http.response.start", "status": status,
                    "headers": [(b"content-type", b"text/plain; charset=utf-8"),
                                (b"content-length", str(len(body)).encode())]})
        await send({"type": "websocket.http.response.body", "body": body})
    else:  # the server answers 403
        await send({"type": "websocket.close", "code": 1008, "reason": text[:100]})
