"""A scene value over a range, as ``--continue`` and ``--along`` give it: ``KEY=a:b`` or
``KEY=a:b:n``, read once for ``rodfem steady`` and ``rodfem periodic``, each command checking
which keys it takes."""

from __future__ import annotations

import math

from rodfem.scene import SCHEMA

MAX_POINTS = 10_000  # values of a sampled range


def parse_range(text: str, option: str, error: type[Exception], name: str = "KEY",
                counted: bool | None = None, example: str = "heat_exchange.k1",
                maximum: int = MAX_POINTS):
    """``text`` → (key, its schema entry, a, b, n): n None without ``:n``. ``counted`` True
    requires ``:n``, False refuses it, None takes either. ``error`` is raised with one line
    naming ``option``: an unknown key, a range that is not ``name=a:b[:n]``, a and b not finite
    or equal, n outside 2..``maximum``."""
    key, sep, span = text.partition("=")
    key = key.strip()
    section, _, entry = key.partition(".")
    found = SCHEMA.get(section, {}).get(entry)
    if found is None:
        raise error(f"{option}: unknown scene key {key!r}; give section.key, e.g. {example}")
    forms = {True: f"{name}=a:b:n", False: f"{name}=a:b",
             None: f"{name}=a:b or {name}=a:b:n"}[counted]
    parts = span.split(":")
    allowed = {True: (3,), False: (2,), None: (2, 3)}[counted]
    try:
        if not sep or len(parts) not in allowed:
            raise ValueError
        a, b = float(parts[0]), float(parts[1])
        n = int(parts[2]) if len(parts) == 3 else None
    except ValueError:
        raise error(f"{option}: {text!r} is not {forms} (reals a, b, a whole number n of "
                    "values)") from None
    if not (math.isfinite(a) and math.isfinite(b)) or a == b or \
            n is not None and not 2 <= n <= maximum:
        raise error(f"{option} {text!r}: a and b must be finite and differ, and 2 <= n <= "
                    f"{maximum}")
    return key, found, a, b, n
