"""What ``rodfem plot`` is asked to draw, read from its options and checked before anything is
drawn: a bad value is one line (:class:`~rodfem.post.runs.PlotError`, exit code 2) and no file.

    --only contact,energy     the figure kinds of :data:`KINDS`
    --no-animation            no rod.gif
    --window T0,T1            the time window drawn
    --labels a,b,c            one label per run, in legends and titles
    --colour-by model.zeta    runs coloured by a scene value, with one colour bar
    --format pdf              the still figures as PNG, PDF or SVG (default: the first run's
                              output.figure_format, else PNG)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from rodfem.post.fields import FUNCTIONS
from rodfem.post.runs import PlotError, Run

# The figure kinds of a run: the curves, each saved field's map (or all maps), the animation.
KINDS = ("contact", "energy", "spacetime", *(f"spacetime_{name}" for name in FUNCTIONS), "rod")


@dataclass(frozen=True)
class Options:
    """What to draw.

    Attributes:
        only: the figure kinds drawn (default: every kind).
        animation: draw rod.gif (where u and θ are saved).
        window: the time interval [t0, t1] drawn, or None for the whole run.
        labels: one label per run, or None for labels made of the runs' names and values.
        colour_by: a scene key whose values colour the runs (a sequential map and a colour
            bar instead of a legend), or None for one colour per run and a legend.
        format: the still figures' format (:data:`rodfem.output.figures.FORMATS`), or None for
            the first run's ``output.figure_format`` (PNG where it has none).
    """

    only: frozenset[str] = frozenset(KINDS)
    animation: bool = True
    window: tuple[float, float] | None = None
    labels: tuple[str, ...] | None = None
    colour_by: str | None = None
    format: str | None = None

    def draws(self, kind: str) -> bool:
        """Whether a figure of this kind (``contact``, ``spacetime_u``, ``rod``...) is drawn."""
        if kind == "rod" and not self.animation:
            return False
        return kind in self.only or (kind.startswith("spacetime_") and "spacetime" in self.only)


EVERYTHING = Options()  # every figure, over the whole run, with the default labels and colours


def _items(text: str, option: str) -> list[str]:
    items = [item.strip() for item in text.split(",")]
    if not text.strip() or any(not item for item in items):
        raise PlotError(f"{option} takes a comma-separated list without empty items, "
                        f"not {text!r}")
    return items


def parse_only(text: str) -> frozenset[str]:
    """``contact,energy`` → the kinds; an unknown name is refused with the allowed ones."""
    kinds = _items(text, "--only")
    unknown = [kind for kind in kinds if kind not in KINDS]
    if unknown:
        raise PlotError(f"--only: unknown figure {unknown[0]!r}; the figures are "
                        f"{', '.join(KINDS)}")
    return frozenset(kinds)


def parse_window(text: str) -> tuple[float, float]:
    """``T0,T1`` → (t0, t1): two finite times, 0 ≤ t0 < t1."""
    items = _items(text, "--window")
    try:
        t0, t1 = (float(item) for item in items)
    except ValueError:
        raise PlotError(f"--window takes two times T0,T1 (e.g. 0,2), not {text!r}") from None
    if not (math.isfinite(t0) and math.isfinite(t1)) or t0 < 0 or t0 >= t1:
        raise PlotError(f"--window {text}: the times must be finite with 0 <= T0 < T1")
    return t0, t1


def parse_labels(text: str) -> tuple[str, ...]:
    """``a,b,c`` → the labels (their number is checked against the runs by :func:`check`)."""
    return tuple(_items(text, "--labels"))


def check(options: Options, runs: list[Run]) -> None:
    """Refuse options that do not fit the runs: labels not one per run, a window after every
    run's end, a colour key that is not a numeric value of every run's scene."""
    if options.labels is not None and len(options.labels) != len(runs):
        raise PlotError(f"--labels gives {len(options.labels)} label"
                        f"{'' if len(options.labels) == 1 else 's'} for {len(runs)} "
                        f"run{'' if len(runs) == 1 else 's'}: give one per run")
    if options.window is not None:
        end = max(float(run.history.t[-1]) for run in runs)
        if options.window[0] >= end:
            raise PlotError(f"--window starts at t = {options.window[0]:g}, after the runs end "
                            f"(t = {end:g})")
    key = options.colour_by
    if key is not None:
        for run in runs:
            value = run.scene.get(key)
            if value is None:
                raise PlotError(f"--colour-by {key}: {run.name}'s scene has no such value "
                                "(give a scene key such as model.zeta)")
            if isinstance(value, bool) or not isinstance(value, (int, float)) \
                    or not math.isfinite(value):
                raise PlotError(f"--colour-by {key}: {run.name}'s value {value!r} is not a "
                                "finite number")
        values = {float(run.scene[key]) for run in runs}
        if len(runs) > 1 and len(values) == 1:
            raise PlotError(f"--colour-by {key}: every run has {key} = {values.pop():g}; "
                            "colour by a value in which the runs differ")
