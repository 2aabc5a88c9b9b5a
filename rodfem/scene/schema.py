"""The scene schema: every key a scene may set, its kind, default, range and meaning.

Every key has a default (the paper's common data and its first experiment), so a scene names only
what differs.
"""

from __future__ import annotations

import dataclasses
from typing import Any


class SceneError(ValueError):
    """A scene value that is wrong: the message names the key and what is allowed, on one line
    (control characters from the user's text, a newline say, are shown escaped)."""

    def __init__(self, message: str):
        super().__init__("".join(c if c.isprintable() else repr(c)[1:-1] for c in str(message)))


@dataclasses.dataclass(frozen=True)
class Key:
    """One scene key: its kind ("real", "integer", "boolean", "choice", "expression", or a list
    of distinct values: "reals", "choices"), default and range (of each value, for a list)."""

    kind: str
    default: Any
    minimum: float | None = None  # inclusive
    above: float | None = None  # exclusive lower bound
    maximum: float | None = None  # inclusive
    choices: tuple[str, ...] = ()
    help: str = ""
    # ("section.key", value): the key applies only where that key has that value (or one of a
    # tuple of values); setting it elsewhere is a mistake, and a resolved scene leaves it out.
    only_with: tuple[str, Any] | None = None

    def applies_with(self, value: Any) -> bool:
        """Whether the key applies where its ``only_with`` key has ``value``."""
        wanted = self.only_with[1]
        return value in wanted if isinstance(wanted, tuple) else value == wanted


# Bounds that keep every derived quantity (1/ε, Δt², b/Δt², the energy) far from overflow and
# the run within memory; far beyond anything physical in the model's units.
BIG, SMALL = 1e12, 1e-12
MAX_CELLS, MAX_STEPS = 10_000_000, 100_000_000
# The methods that solve each step of (3.1)–(3.2): the fastest exact one is the default.
METHODS = ("direct", "newton", "picard")
TIME_SCHEMES = ("paper", "crank-nicolson")
# time.tolerance = 0: the tolerance of each time scheme that holds the peak contact stress of the
# stiff-obstacle study within 1 % (benchmarks/bench_adaptive_peak.py): the first-order scheme's
# error over a contact grows as the square root of its tolerance, the second-order one's faster.
TOLERANCES = {"paper": 5e-5, "crank-nicolson": 1e-3}
EXCHANGE_LAWS = ("constant", "pressure", "gap")  # rodfem.model.exchange
MASSES = ("lumped", "consistent", "redistributed", "redistributed-lumped", "dispersion-free")
# The masses with none at the contact node x = 1: it is moved to its neighbour.
REDISTRIBUTED = ("redistributed", "redistributed-lumped", "dispersion-free")
# What a run can save and record besides the default history (rodfem.output.columns, .fields).
FIELDS = ("theta", "u", "sigma", "velocity", "heat_flux")
QUANTITIES = ("theta_1", "heat_flux_1", "contact_force", "contact", "penetration")
FIGURE_FORMATS = ("png", "pdf", "svg")  # rodfem.output.figures
# Sections a resolved scene writes only where one of their keys is not the default.
OPTIONAL_SECTIONS = ("accuracy",)


SCHEMA: dict[str, dict[str, Key]] = {
    "model": {
        "a": Key("real", 0.017, minimum=0.0, maximum=BIG, help="thermal coupling"),
        "b": Key("real", 1.0, minimum=0.0, maximum=BIG, help="inertia"),
        "zeta": Key("real", 0.2, minimum=0.0, maximum=BIG, help="Kelvin-Voigt viscosity"),
        "k": Key("real", 1.0, minimum=0.0, maximum=BIG, help="heat exchange at x = 1"),
        "theta_A": Key("real", 10.0, minimum=-BIG, maximum=BIG, help="temperature at x = 0"),
    },
    "obstacle": {
        "epsilon": Key("real", 0.01, minimum=SMALL, maximum=BIG,
                       help="compliance: stiffness is 1/epsilon"),
        "gap": Key("real", 0.1, minimum=-BIG, maximum=BIG,
                   help="distance g of the obstacle from x = 1"),
        "kind": Key("choice", "elastic", choices=("elastic", "rigid"),
                    help="elastic: a penalty law (obstacle.law); rigid: Signorini, "
                    "u(1) <= g (epsilon unused)"),
        "law": Key("choice", "linear", choices=("linear", "power"),
                   help="the elastic obstacle's reaction: linear, the paper's "
                   "(1/epsilon)[u(1) - g]_+; power, normal compliance "
                   "(1/epsilon)[u(1) - g]_+^exponent"),
        "exponent": Key("real", 1.0, minimum=1.0, maximum=100.0,
                        only_with=("obstacle.law", "power"), help="m >= 1 of the power law"),
        "temperature": Key("real", 0.0, minimum=-BIG, maximum=BIG,
                           help="temperature theta_O of the obstacle, with which the rod "
                           "exchanges heat at x = 1"),
    },
    # The heat the rod gives the obstacle at x = 1, -theta_x(1) = h (theta(1) - theta_O), with
    # h = k + q: q from the law (rodfem.model.exchange).
    "heat_exchange": {
        "law": Key("choice", "constant", choices=EXCHANGE_LAWS,
                   help="h at the contact: constant, h = k (the paper's); pressure, "
                   "h = k + k1 p^exponent with p = -sigma(1) the contact pressure; gap, "
                   "h = k + k1 exp(min(u(1) - g, 0)/length)"),
        "k1": Key("real", 1.0, minimum=0.0, maximum=BIG,
                  only_with=("heat_exchange.law", ("pressure", "gap")),
                  help="the exchange the contact adds to k: at unit pressure (pressure), in "
                  "contact (gap)"),
        "exponent": Key("real", 1.0, above=0.0, maximum=100.0,
                        only_with=("heat_exchange.law", "pressure"),
                        help="m > 0 of the pressure law"),
        "length": Key("real", 0.01, above=0.0, maximum=BIG,
                      only_with=("heat_exchange.law", "gap"),
                      help="the gap over which the exchange falls by a factor e (gap law)"),
    },
    "initial": {
        "theta0": Key("expression", "theta_A*(cos(2*pi*x) - sin(pi*x/2))",
                      help="initial temperature, in x and the model's names; theta_A at x = 0"),
        "u0": Key("expression", "0", help="initial displacement, in x; 0 at x = 0"),
        "u1": Key("expression", "20*x*(x - 1)**2",
                  help="initial velocity; not used when b = 0 (quasi-static)"),
    },
    "mesh": {"cells": Key("integer", 250, minimum=2, maximum=MAX_CELLS,
                          help="cells of the uniform mesh of (0, 1): h = 1/cells")},
    "time": {
        "dt": Key("real", 0.001, minimum=SMALL, maximum=BIG, help="time step"),
        "end": Key("real", 8.0, minimum=SMALL, maximum=BIG,
                   help="end time T, a whole number of steps"),
        "scheme": Key("choice", "paper", choices=TIME_SCHEMES,
                      help="paper: the scheme (3.1)-(3.2), first order; crank-nicolson: the "
                      "midpoint rule, second order (docs/time-schemes.md)"),
        "adaptive": Key("boolean", False,
                        help="true: the step adapts to keep each step's error estimate within "
                        "time.tolerance, and a step ends where contact begins or ends; "
                        "time.dt is then the first step"),
        "tolerance": Key("real", 0.0, minimum=0.0, maximum=0.1,
                         only_with=("time.adaptive", True),
                         help="the error allowed per step, relative to the size of each field "
                         "(temperature, velocity, displacement, contact force) over the run so "
                         "far; 0: by the time scheme, 5e-5 for paper, 1e-3 for crank-nicolson, "
                         "which hold a stiff contact's peak stress within 1 % "
                         "(docs/time-schemes.md)"),
        "dt_min": Key("real", 1e-9, minimum=SMALL, maximum=BIG,
                      only_with=("time.adaptive", True),
                      help="the smallest step the error control may take (a step located at a "
                      "contact event may be shorter); below it the run stops"),
        "dt_max": Key("real", 0.0, minimum=0.0, maximum=BIG,
                      only_with=("time.adaptive", True),
                      help="the largest step; 0: no bound but the end time"),
    },
    "discretisation": {
        "mass": Key("choice", "lumped", choices=MASSES,
                    help="lumped: the paper's (vertex quadrature); consistent: exact; "
                    "redistributed: consistent, with the mass of the contact node x = 1 moved "
                    "to its neighbour (for stiff and rigid contact, docs/time-schemes.md); "
                    "redistributed-lumped: the same from the lumped mass; dispersion-free: "
                    "redistributed, from consistent and lumped blended by 1/2 + (dt/h)^2, which "
                    "cancels Crank-Nicolson's leading dispersion error (crank-nicolson, "
                    "dt <= h only)"),
    },
    "solver": {
        "method": Key("choice", "direct", choices=METHODS,
                      help="direct: one solve per step, exact; newton: SNES semismooth Newton; "
                      "picard: the paper's iteration (3.3)-(3.4)"),
        "tol": Key("real", 1e-10, minimum=1e-300, maximum=BIG,
                   help="picard: max-norm of the change between two iterations"),
        "max_iterations": Key("integer", 100, minimum=1, maximum=1_000_000,
                              help="picard and newton: iterations allowed per step"),
    },
    # Body sources f of θ_t − θ_xx + a u_xt = f and b u_tt − σ_x = f, in x, t and the model's
    # names: for manufactured solutions (rodfem.model.manufactured). "0" costs nothing.
    "source": {
        "heat": Key("expression", "0", help="source of the heat equation, in x and t"),
        "momentum": Key("expression", "0", help="source of the momentum equation, in x and t"),
    },
    # A run told how accurate its declared measures must be chooses its own mesh and steps
    # (rodfem.studies.accuracy); the section is written only where a key differs from its default.
    "accuracy": {
        "target": Key("real", 0.0, minimum=0.0, maximum=0.5,
                      help="the relative error wanted on every declared measure (a measure may "
                      "give its own target); the run then refines mesh.cells and the time step "
                      "(time.tolerance, or time.dt with fixed steps) until each measure's "
                      "estimated error is within it; 0: no target, the scene's mesh and steps"),
        "cells_max": Key("integer", 0, minimum=0, maximum=MAX_CELLS,
                         help="the most cells the refinement may take; 0: 64 times mesh.cells, "
                         "at most 100000"),
        "runs_max": Key("integer", 10, minimum=3, maximum=100,
                        help="the most runs the refinement may make, the run reported "
                        "included"),
    },
    "output": {
        "every": Key("integer", 0, minimum=0, maximum=MAX_STEPS,
                     help="save fields every n steps; 0: every 50 steps, or less often in a "
                     "long run so that it saves about 200 frames at most; with adaptive steps, "
                     "at the first step of each interval of n steps of time.dt"),
        "fields": Key("choices", ("theta", "u", "sigma"), choices=FIELDS,
                      help="the fields saved in fields.xdmf: theta (temperature), u "
                      "(displacement), velocity (nodes); sigma (stress), heat_flux (-theta_x, "
                      "per cell); at least one"),
        "history": Key("choices", (), choices=QUANTITIES,
                       help="quantities history.h5 records besides t, u_1, u_half, ut_1, "
                       "sigma_1, energy and iterations (docs/outputs.md)"),
        "probes": Key("reals", (), minimum=0.0, maximum=1.0,
                      help="points x of the rod where history.h5 records u@x, theta@x and "
                      "sigma@x"),
        "history_every": Key("integer", 1, minimum=1, maximum=MAX_STEPS,
                             help="keep the history's row of every n-th step (n = 0, n, 2n, "
                             "...; adaptive steps too, by their count); the energy check and "
                             "iteration counts still see every step"),
        "checkpoint": Key("real", 5.0, minimum=0.0, maximum=BIG,
                          help="write a checkpoint (history, fields and the state to resume "
                          "from) at the first field save this many seconds of wall time after "
                          "the last one; 0: at every field save"),
        "figure_format": Key("choice", "png", choices=FIGURE_FORMATS,
                             help="the format of the still figures rodfem draws of this scene "
                             "(rodfem plot, fit, sensitivity, steady): png, pdf or svg; a "
                             "command's --format overrides it"),
    },
}


@dataclasses.dataclass(frozen=True)
class TopKey:
    """A key at the top of a scene file, outside its sections: its kind in words ("text", a
    "table"), its default (None: none) and meaning."""

    kind: str
    default: Any
    help: str


# The keys at the top of a scene file. BASE names the scene this one is set over; it is read
# first (rodfem.scene.files.based) and is not part of the resolved scene, whose top-level keys
# are TOP_LEVEL, with their defaults. The entries of [measures]: rodfem.scene.measures.
BASE = "scene"
TOP_KEYS = {
    "description": TopKey("text", "", "free text, recorded with the run; setting keys over a "
                          "scene names them in its description"),
    BASE: TopKey("text", None, "the base scene whose keys this file's are set over, key by "
                 "key: a built-in name, or a TOML file relative to this one (which may name a "
                 "base of its own)"),
    "measures": TopKey("table", {}, "the measures every run reduces from its history, one "
                       "entry each (their keys: the [measures] section below)"),
}
TOP_LEVEL = {name: key.default for name, key in TOP_KEYS.items() if name != BASE}
MODEL_NAMES = tuple(SCHEMA["model"])
SOURCE_NAMES = (*MODEL_NAMES, "t")
BUILTIN = tuple(f"paper{i}" for i in range(1, 6))  # the paper's experiments
# Other built-in scenes: manufactured solutions without contact, with sources
# (rodfem.model.manufactured; one with a gap-dependent heat exchange), an impact on a rigid wall
# with an exact solution (rodfem.model.impact), paper1 against a stiff obstacle, for its peak
# contact stress, and Barber's thermoelastic contact, with three steady states (rodfem steady
# barber)
EXTRA = ("manufactured", "manufactured-gap", "impact", "stiff", "barber")
