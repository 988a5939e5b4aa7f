"""Transport URLs: parse ``spy+faulty+sim://?drop=0.01&log=-`` into checked, typed layers.

Grammar (one query string at the very end, for the whole chain)::

    URL     = { WRAPPER "+" } BASE [ "?" OPTION { "&" OPTION } ]
    WRAPPER = "faulty" | "spy"
    BASE    = "sim://"                     the emulated board in this process
            | "serial://" DEVICE           a serial device (percent-escapes decoded)
            | DEVICE                       the same, written plainly: /dev/ttyACM0, COM3
    OPTION  = NAME "=" VALUE | NAME        (a bare NAME means NAME=1, for on/off options)

Which layer an option goes to: every option name belongs to exactly one scheme (see
:mod:`parolkit.transport.schemes`), and goes to that scheme's layer.  An option whose scheme is
not in the URL is an error (``sim://?baud=9600``), as is the same wrapper twice.  Wrappers
apply outermost first: in ``spy+faulty+sim://`` the spy sees the bytes as the controller
writes them and as they come out of the fault injector.

Only the standard library is used: parsing a URL never imports pyserial or the emulator.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from urllib.parse import quote, unquote

from parolkit.transport.options import Option, OptionKind, TransportURLError
from parolkit.transport.schemes import (
    DEVICE_SCHEME,
    SCHEMES,
    Scheme,
    base_schemes,
    owner_of,
    wrapper_schemes,
)

__all__ = ["Layer", "TransportURL", "TransportURLError", "parse_transport_url"]

_WRAPPER = re.compile(r"([A-Za-z][A-Za-z0-9_.-]*)\+")
_SCHEME = re.compile(r"([A-Za-z][A-Za-z0-9_.+-]*)://")
_SCHEME_WITHOUT_SLASHES = re.compile(r"([A-Za-z][A-Za-z0-9_.-]*):(?!//)")


def _known() -> str:
    bases = ", ".join(s.prefix for s in base_schemes())
    wrappers = ", ".join(s.prefix for s in wrapper_schemes())
    return f"links: {bases} or a device path such as /dev/ttyACM0; wrappers: {wrappers}"


@dataclass(frozen=True)
class Layer:
    """One scheme of a URL and the options given for it (URL name -> checked value)."""

    scheme: Scheme
    options: dict[str, object] = field(default_factory=dict)

    def keywords(self) -> dict[str, object]:
        """The options as constructor keywords (``drop`` -> ``drop_rate``)."""
        out: dict[str, object] = {}
        for name, value in self.options.items():
            opt = self.scheme.option(name)
            assert opt is not None
            out[opt.keyword] = value
        return out


@dataclass(frozen=True)
class TransportURL:
    """A parsed URL: ``layers`` outermost first (the last one is the link itself).

    ``device`` is the serial device of a ``serial`` link (None for ``sim://``); ``text`` is
    what was parsed.  :meth:`with_options` adds Python-side options; ``str()`` gives the
    canonical URL (``serial://`` written out, options in a fixed order).
    """

    text: str
    layers: tuple[Layer, ...]
    device: str | None = None

    @property
    def base(self) -> Layer:
        """The link at the end of the chain (``sim`` or ``serial``)."""
        return self.layers[-1]

    @property
    def wrappers(self) -> tuple[Layer, ...]:
        return self.layers[:-1]

    @property
    def schemes(self) -> tuple[str, ...]:
        """Scheme names outermost first, e.g. ``("spy", "faulty", "sim")``."""
        return tuple(layer.scheme.name for layer in self.layers)

    @property
    def simulated(self) -> bool:
        """True when the link is the in-process emulated board."""
        return self.base.scheme.name == "sim"

    def layer(self, scheme: str) -> Layer | None:
        return next((la for la in self.layers if la.scheme.name == scheme), None)

    def get(self, name: str, default: object = None) -> object:
        """The value this URL gives option ``name`` (URL name or keyword alias), else
        ``default`` (also when the option's scheme is not in the URL).  E.g. the effective
        homing speed-up: ``url.with_options(defaults=...).get("speedup", 1.0)``."""
        owner = owner_of(name)
        layer = self.layer(owner.name) if owner is not None else None
        if owner is None or layer is None:
            return default
        opt = owner.option(name)
        assert opt is not None
        return layer.options.get(opt.name, default)

    def _allowed(self) -> str:
        names = [name for la in self.layers for name in la.scheme.option_names]
        return ", ".join(names)

    def _layer_for(self, name: str, given_as: str) -> tuple[Layer, Option] | None:
        """The layer that takes option ``name``; None when its scheme is not in this URL."""
        owner = owner_of(name)
        if owner is None:
            raise TransportURLError(
                f"unknown transport option {name!r} ({given_as}); options of "
                f"{self.chain!r}: {self._allowed()}")
        layer = self.layer(owner.name)
        if layer is None:
            return None
        opt = owner.option(name)
        assert opt is not None
        return layer, opt

    @property
    def chain(self) -> str:
        """The schemes as written, e.g. ``spy+faulty+sim://``."""
        return "".join(la.scheme.prefix for la in self.layers)

    def with_options(self, overrides: Mapping[str, object] | None = None,
                     defaults: Mapping[str, object] | None = None) -> TransportURL:
        """A copy with Python-side options added.  Names are URL names or keyword aliases.

        * ``overrides`` replace what the URL says; naming an option of a scheme that is not in
          the URL is an error.
        * ``defaults`` apply only where the URL and ``overrides`` say nothing, and are skipped
          for schemes not in the URL (so one call can carry a baud for a serial link and a
          homing speed-up for the emulator); an unknown name is still an error.

        A value of None means "not given".  Values are checked like URL text (a string is
        read as URL text, a number or bool must fit the option).
        """
        new = [Layer(la.scheme, dict(la.options)) for la in self.layers]
        copy = TransportURL(self.text, tuple(new), self.device)
        set_by_override: dict[str, str] = {}
        for name, value in (overrides or {}).items():
            if value is None:
                continue
            found = copy._layer_for(name, "given as a keyword")
            if found is None:
                owner = owner_of(name)
                assert owner is not None
                raise TransportURLError(
                    f"option {name!r} belongs to {owner.prefix}, which {self.chain!r} does not "
                    f"use; options of {self.chain!r}: {self._allowed()}")
            layer, opt = found
            if opt.name in set_by_override:
                raise TransportURLError(
                    f"option {opt.name!r} given twice (as {set_by_override[opt.name]!r} and "
                    f"{name!r})")
            set_by_override[opt.name] = name
            layer.options[opt.name] = opt.convert(value, layer.scheme.prefix)
        for name, value in (defaults or {}).items():
            if value is None:
                continue
            found = copy._layer_for(name, "given as a default")
            if found is None:
                continue
            layer, opt = found
            if opt.name not in layer.options:
                layer.options[opt.name] = opt.convert(value, layer.scheme.prefix)
        return copy

    def __str__(self) -> str:
        head = "".join(la.scheme.prefix for la in self.wrappers)
        if self.device is not None:
            head += "serial://" + quote(self.device, safe="/\\:._-~")
        else:
            head += self.base.scheme.prefix
        pairs = []
        for la in self.layers:
            for opt in la.scheme.options:
                if opt.name in la.options:
                    pairs.append(f"{opt.name}={_text(la.options[opt.name])}")
        return head + ("?" + "&".join(pairs) if pairs else "")


def _text(value: object) -> str:
    if isinstance(value, bool):
        return "1" if value else "0"
    if isinstance(value, float):
        return repr(value)
    return quote(str(value), safe="/\\:._-~")


def parse_transport_url(url: str) -> TransportURL:
    """Parse and check ``url``; raises :class:`TransportURLError` naming what is wrong.

    Checks the scheme names, that each option belongs to a scheme of this URL, and each
    value's type and range.  Nothing is opened or imported beyond the standard library.
    """
    if not isinstance(url, str):
        raise TransportURLError(f"a transport URL must be a string, got {type(url).__name__}")
    text = url.strip()
    if not text:
        raise TransportURLError(f"empty transport URL; {_known()}")
    rest = text
    chain: list[Scheme] = []
    while (m := _WRAPPER.match(rest)) is not None:
        name = m.group(1).lower()
        scheme = SCHEMES.get(name)
        if scheme is None:
            raise TransportURLError(f"unknown wrapper {m.group(0)!r} in {text!r}; {_known()}")
        if not scheme.wrapper:
            raise TransportURLError(
                f"{scheme.prefix} is a link, not a wrapper: it must come last, "
                f"e.g. spy+{scheme.prefix} (in {text!r})")
        if scheme in chain:
            raise TransportURLError(f"wrapper {scheme.prefix} appears twice in {text!r}")
        chain.append(scheme)
        rest = rest[m.end():]
    body, has_query, query = rest.partition("?")
    if not body:
        after = f"after {''.join(s.prefix for s in chain)!r}" if chain else "before '?'"
        raise TransportURLError(f"no link {after} in {text!r}; {_known()}")
    device: str | None = None
    if (m := _SCHEME.match(body)) is not None:
        name = m.group(1).lower()
        scheme = SCHEMES.get(name)
        if scheme is None:
            raise TransportURLError(f"unknown transport scheme '{name}://' in {text!r}; {_known()}")
        if scheme.wrapper:
            raise TransportURLError(
                f"{name} is a wrapper: write {scheme.prefix}LINK, e.g. {scheme.prefix}sim:// "
                f"(in {text!r})")
        target = body[m.end():]
        if scheme.takes_device:
            device = unquote(target)
            if not device:
                raise TransportURLError(
                    f"{scheme.prefix} needs a device, e.g. {scheme.prefix}/dev/ttyACM0 "
                    f"(in {text!r})")
        elif target:
            raise TransportURLError(
                f"{scheme.prefix} takes no path (got {target!r}); options go after '?', "
                f"e.g. {scheme.prefix}?speedup=20")
    else:
        m2 = _SCHEME_WITHOUT_SLASHES.match(body)
        if m2 is not None and m2.group(1).lower() in SCHEMES:
            raise TransportURLError(f"write {m2.group(1).lower()}:// (with two slashes) in {text!r}")
        scheme = SCHEMES[DEVICE_SCHEME]
        device = body
    chain.append(scheme)
    parsed = TransportURL(text, tuple(Layer(s) for s in chain), device)
    if has_query:
        _apply_query(parsed, query)
    return parsed


def _apply_query(parsed: TransportURL, query: str) -> None:
    for piece in query.split("&"):
        if not piece:
            continue
        raw_name, has_value, raw_value = piece.partition("=")
        name = unquote(raw_name).strip()
        if not name:
            raise TransportURLError(f"an option without a name ({piece!r}) in {parsed.text!r}")
        owner = owner_of(name)
        opt = owner.option(name) if owner is not None else None
        if owner is None or opt is None or opt.name != name:
            hint = f" (did you mean {opt.name!r}?)" if opt is not None else ""
            raise TransportURLError(
                f"unknown option {name!r} in {parsed.text!r}{hint}; options of "
                f"{parsed.chain!r}: {parsed._allowed()}")
        layer = parsed.layer(owner.name)
        if layer is None:
            raise TransportURLError(
                f"option {name!r} belongs to {owner.prefix}, which {parsed.text!r} does not "
                f"use; options of {parsed.chain!r}: {parsed._allowed()}")
        if name in layer.options:
            raise TransportURLError(f"option {name!r} appears twice in {parsed.text!r}")
        if not has_value:
            if opt.kind is not OptionKind.BOOL:
                raise TransportURLError(
                    f"option {name!r} needs a value ({name}={opt.allowed}) in {parsed.text!r}")
            raw_value = "1"
        layer.options[name] = opt.convert(unquote(raw_value), owner.prefix)
