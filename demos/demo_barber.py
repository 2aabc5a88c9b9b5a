# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: light
# ---

# # Barber's thermoelastic contact: steady states, their stability, and the runs that choose
#
# Run it with `mpirun -n 2 python3 demos/demo_barber.py` (or without `mpirun`); it writes its
# tables and figures into `results/demo_barber`. With `CI` set in the environment it uses coarser
# meshes, fewer values and shorter runs.
#
# Heat crosses a contact the better the harder it is pressed. Barber saw that this alone makes
# thermoelastic contact lose uniqueness: a rod pressed against a hot obstacle warms, expands and
# presses harder, so it can rest separated or pressed. At $x = 1$ the rod exchanges heat with an
# obstacle at temperature $\theta_O$ (`obstacle.temperature`),
#
# $$-\theta_x(1, t) = h\,(\theta(1, t) - \theta_O), \qquad h = k + k_1 p^m,$$
#
# with $p = -\sigma(1) \ge 0$ the contact pressure of the obstacle's law (0 when separated):
# `heat_exchange.law = "pressure"`, `k1` $= k_1$, `exponent` $= m$.
#
# At rest ($u_t = \theta_t = 0$) the temperature is linear, $\theta(1) = (\theta_A + h\theta_O)
# /(1 + h)$, the stress constant, and $u(1) = -p + a(\theta_A + \theta(1))/2$: with the contact
# law, one scalar equation in $p$ whose every root `rodfem steady` finds
# (docs/thermal-contact.md). Each state's stability is the sign of its growth rate, the largest
# real part of the spectrum of the dynamic problem linearised about it.

# +
import math
import os
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from mpi4py import MPI

import rodfem
import rodfem.scene
from rodfem.post import style
from rodfem.post.bifurcation import plot_curves
from rodfem.post.steady import plot_branches
from rodfem.studies.steady import barber, curves, periodic
from rodfem.studies.steady import states as analysis
from rodfem.studies.steady.diagram import point_lines

COMM = MPI.COMM_WORLD
SHORT = bool(os.environ.get("CI"))
OUT = Path("results/demo_barber")
FIGURES = OUT / "figures"
STEADY = OUT / "steady"  # rodfem steady's directory: steady.csv, branches.csv, its figure
CELLS = 40 if SHORT else 100
DT = 0.001


def say(*args) -> None:
    if COMM.rank == 0:
        print(*args, flush=True)


def save(fig: Figure, name: str) -> None:
    """Rank 0 writes figures/name."""
    if COMM.rank == 0:
        FIGURES.mkdir(parents=True, exist_ok=True)
        fig.tight_layout()
        fig.savefig(FIGURES / name, dpi=style.MPL_DPI)


def table(found) -> None:
    say(f"{'u(1)':>10} {'sigma(1)':>10} {'theta(1)':>9} {'contact':>8} {'growth rate':>12}")
    for state, eigenvalues in found:
        say(f"{state.u_1:10.6f} {state.sigma_1:10.6f} {state.theta_1:9.4f} "
            f"{'yes' if state.contact else 'no':>8} {eigenvalues[0].real:12.5g}"
            + ("  unstable" if eigenvalues[0].real > 0 else ""))


# -

# ## The problem: a cool rod, a hot obstacle
#
# The built-in scene `barber`: the clamped end at $\theta_A = 0$, the obstacle at
# $\theta_O = 10$ behind a gap $g = 0.02$, $k = 0.1$ through the gap and $k + k_1 p$ with
# $k_1 = 1000$ in contact, $\varepsilon = 0.01$, $\zeta = 0.5$. Separated, the end warms only to
# $\theta(1) = 10k/(1+k) = 0.91$ and stops short of the gap; pressed, it nearly reaches the
# obstacle's temperature and presses harder. Its steady states:

# +
BASE = [f"mesh.cells={CELLS}", f"time.dt={DT}", "solver.method=direct"]
found = barber.states(rodfem.scene.load("barber", BASE))
table(found)
(separated, rate_s), (middle, rate_m), (pressed, rate_p) = found
# -

# Three states: separated and pressed are stable, the lightly pressed one between them unstable
# with a real eigenvalue (a small push decides which of the other two the rod falls to). The
# separated state's growth rate is the first vibration's damping, $-\zeta(\pi/2)^2/2$; the
# pressed one's is $-1/\zeta$, where the Kelvin–Voigt rod's short waves crowd.
#
# ## The branches over the obstacle's temperature
#
# `rodfem steady barber --continue obstacle.temperature=0:40` follows the states as $\theta_O$
# rises, by continuation along the curve of the scalar equation's roots, and locates the points
# on it: the separated branch ends at a grazing point, where the warm end reaches the gap and
# the branch turns back pressed and unstable, down to a fold, where it turns again, pressed and
# stable. Between them the rod has three states. The folds and grazing points are exact on any
# mesh (the states are); the Hopf points near the fold, where a complex pair crosses, are the
# mesh's.

# +
diagram = rodfem.bifurcation("barber", "obstacle.temperature", 0.0, 40.0, BASE)
states = rodfem.steady("barber", BASE)
analysis.write(STEADY, True, COMM, states, diagram["branches"], diagram["points"])
if COMM.rank == 0:
    plot_branches(STEADY, "obstacle.temperature", gap=0.02)
for line in point_lines(diagram["points"], "obstacle.temperature"):
    say(line)
# -

# Over a second value the folds (and the grazing point, a fold at a corner) trace the region
# where the rod can rest in two stable states: `--follow fold --along heat_exchange.k1=c:d`.
# The grazing point does not move with $k_1$ ($\theta_O = 2g(1 + k)/(ak)$ holds no $k_1$); the
# fold moves to cooler obstacles as the contact conducts better.

# +
scene = rodfem.scene.load("barber", BASE)
along = np.linspace(200.0, 2000.0, 10 if SHORT else 37)
followed = curves.follow(scene, "obstacle.temperature", 0.0, 40.0, "heat_exchange.k1", along,
                         "fold", None)
grid = curves.counts(scene, "obstacle.temperature", 0.0, 40.0, "heat_exchange.k1", 200.0,
                     2000.0)
analysis.write(OUT / "two-values", True, COMM, states, None, None, followed, grid)
if COMM.rank == 0:
    plot_curves(OUT / "two-values")
for k1 in (along[0], along[-1]):
    here = sorted(r["parameter"] for r in followed if r["parameter2"] == k1)
    say(f"k1 = {k1:g}: three states for {here[0]:.6f} < theta_O < {here[-1]:.6f}")
# -

# ## Two starts, two stable states
#
# A cold start (the scene's: $\theta_0 = 0$, $u_0 = 0$) warms through the gap and never reaches
# it; a hot one (the rod at the obstacle's temperature, $\theta_0 = 10x$, at rest) expands into
# the obstacle and stays pressed. The analysis says where each settles and how fast: about a
# stable state a step of the paper's scheme (backward Euler on $(\Theta, U, \delta)$) multiplies the
# mode of an eigenvalue $\lambda$ by $1/(1 - \lambda\Delta t)$, so the distance shrinks as
# $e^{\mu t}$, $\mu = -\ln(1 - \lambda\Delta t)/\Delta t$ for the slowest mode. The cold
# start's distance follows it from $t = 2$ on; the hot start's falls faster, because the pressed
# state's slowest modes, the short waves, are hardly excited by this start: the rate is
# a bound there, not a prediction.

# +
END = 16 if SHORT else 24
cold = barber.run("barber", [*BASE, f"time.end={END}"])
hot = barber.run("barber", [*BASE, f"time.end={END}", "initial.theta0=10*x"])
for name, run, (state, eigenvalues) in (("cold", cold, found[0]), ("hot", hot, found[2])):
    mu = barber.step_rate(eigenvalues[0], DT).real
    say(f"{name} start, t = {run.t[-1]:g}: u(1) = {run.u_1[-1]:.10f} (predicted "
        f"{state.u_1:.10f}), sigma(1) = {run.sigma_1[-1]:.8f} ({state.sigma_1:.8f}), theta(1) = "
        f"{run.theta_1[-1]:.8f} ({state.theta_1:.8f}); rate mu = {mu:.4f}")
period = 2 * math.pi / abs(rate_s[0].imag)
measured = barber.decay_rate(cold.t, cold.u_1 - separated.u_1, (6, 6 + period),
                             (6 + 2 * period, 6 + 3 * period))
say(f"cold start: |u(1) - u*| shrinks at {measured:.4f} per unit time "
    f"(predicted {barber.step_rate(rate_s[0], DT).real:.4f})")

with style.mpl_fonts():
    fig = Figure(figsize=(style.MPL_SIZE[0], 1.3 * style.MPL_SIZE[1]))
    top, middle, bottom = fig.subplots(3, 1, sharex=True)
    for i, (name, run, (state, eigenvalues)) in enumerate((("cold start", cold, found[0]),
                                                           ("hot start", hot, found[2]))):
        top.plot(run.t, run.u_1, color=style.colour(i), label=name)
        middle.plot(run.t, run.theta_1, color=style.colour(i))
        bottom.semilogy(run.t, np.abs(run.u_1 - state.u_1), color=style.colour(i))
        mu = barber.step_rate(eigenvalues[0], DT).real
        t = np.linspace(2, END, 2)
        start = barber.envelope(run.t, run.u_1 - state.u_1, 2, 2 + period)
        bottom.semilogy(t, start * np.exp(mu * (t - 2)), "--", color=style.colour(i),
                        label=f"e^(μt), μ = {mu:.3f}")
    for state, eigenvalues in found:
        stable = eigenvalues[0].real < 0
        for ax, value in ((top, state.u_1), (middle, state.theta_1)):
            ax.axhline(value, color="k" if stable else "0.6", linestyle="--", linewidth=1)
    top.axhline(0.02, color="0.8", linewidth=4, zorder=0, label="gap g")
    top.set_ylabel("$u(1)$")
    middle.set_ylabel(r"$\theta(1)$")
    bottom.set_ylabel("$|u(1) - u^*|$")
    bottom.set_ylim(1e-16, 1e-1)
    bottom.set_xlabel("t")
    top.set_title("Two starts, two stable states (dashed: steady states, grey: unstable)")
    top.legend(fontsize=style.MPL_LEGEND_SIZE)
    bottom.legend(fontsize=style.MPL_LEGEND_SIZE)
    save(fig, "two_starts.png")
# -

# ## A hot rod against a cool obstacle: an oscillatory instability
#
# Turn the heat around: $\theta_A = 10$, $\theta_O = 0$. Pressing now cools the end, which
# contracts and lets go, which lets it warm and press again: a negative feedback, so the steady
# state is unique. But the feedback acts with the delay of the heat's diffusion and through the
# rod's inertia: with a strong exchange ($k_1 = 1000$, $m = 2$, $g = 0.11$, $\varepsilon = 0.1$)
# and little viscosity a complex pair of eigenvalues, the rod's second vibration, crosses into
# the right half-plane as $\zeta$ falls: a Hopf bifurcation.

# +
HOPF = ["model.theta_A=10", "initial.theta0=10", "obstacle.temperature=0",
        "heat_exchange.k1=1000", "heat_exchange.exponent=2", "obstacle.gap=0.11",
        "obstacle.epsilon=0.1", f"mesh.cells={40 if SHORT else 80}", f"time.dt={DT}",
        "solver.method=direct"]


def rightmost(zeta: float):
    """The hot rod's steady state at ``zeta`` and its eigenvalues of Im λ ≥ 0, rightmost first."""
    (state, eigenvalues), = barber.states(rodfem.scene.load("barber", [*HOPF,
                                                                     f"model.zeta={zeta}"]))
    return state, eigenvalues[eigenvalues.imag >= 0]


def vibration(eigenvalues, low: float, high: float) -> complex:
    """The rightmost eigenvalue with low < Im λ < high: one vibration's, followed over ζ."""
    return eigenvalues[(eigenvalues.imag > low) & (eigenvalues.imag < high)][0]


BANDS = {"first vibration": (1.0, 4.0), "second vibration": (4.0, 8.0)}
zetas = np.linspace(0.005, 0.04, 15 if SHORT else 36)
spectra = [rightmost(z)[1] for z in zetas]
second = np.array([vibration(e, *BANDS["second vibration"]) for e in spectra])
# the Hopf point, located on the state's (vertical) branch over ζ, and with the full demo the
# rod's own, extrapolated in h² from 80, 160 and 320 cells
hopf_points = rodfem.bifurcation("barber", "model.zeta", 0.005, 0.04, HOPF,
                                 extrapolate=not SHORT)["points"]
(hopf,) = [p for p in hopf_points if p["kind"] == "hopf"]
lo, onset = hopf["parameter"], complex(0.0, hopf["omega"])
say(f"Hopf bifurcation at zeta = {lo:.8f} ({40 if SHORT else 80} cells): eigenvalues "
    f"+-{onset.imag:.6f} i (period {hopf['period']:.6f})")
if not SHORT:
    say(f"the rod's: zeta = {hopf['parameter_continuum']:.7f} +- {hopf['parameter_error']:.1e}, "
        f"period {hopf['period_continuum']:.6f} +- {hopf['period_error']:.1e}")
alone = all(np.count_nonzero(e.real > 0) == (z < lo) and (z >= lo or e[0] == v)
            for z, e, v in zip(zetas, spectra, second, strict=True))
say(f"below it the second vibration is the one unstable pair, above it none is: {alone}")
state, eigenvalues = rightmost(0.01)
say(f"zeta = 0.01: u(1) = {state.u_1:.6f}, p = {state.p:.6f}, theta(1) = {state.theta_1:.4f}; "
    f"rightmost pairs {eigenvalues[0]:.5f}, {eigenvalues[1]:.5f}")
(_, massless), = barber.states(rodfem.scene.load("barber", [*HOPF, "model.zeta=0.01",
                                                           "model.b=0"]))
say(f"without inertia (b = 0) the same state is stable: growth rate {massless[0].real:.3f}")

with style.mpl_fonts():
    fig = Figure(figsize=style.MPL_SIZE)
    ax = fig.subplots()
    for j, (name, band) in enumerate(BANDS.items()):
        followed = np.array([vibration(e, *band) for e in spectra])
        ax.plot(zetas, followed.real, "o-", color=style.colour(j),
                label=f"{name} (Im λ from {followed.imag.min():.2f} to "
                f"{followed.imag.max():.2f})")
    ax.plot(zetas, [barber.step_rate(v, DT).real for v in second], "--", color=style.colour(1),
            label=f"second vibration's Re μ, the paper's scheme with Δt = {DT}")
    ax.axhline(0, color="k", linewidth=1)
    ax.axvline(lo, color="0.6", linestyle="--", label=f"Hopf, ζ = {lo:.4f}")
    ax.set_xlabel("ζ (model.zeta)")
    ax.set_ylabel("growth rate Re λ")
    ax.set_title("The hot rod's steady state: its vibrations' eigenvalues over ζ")
    ax.legend(fontsize=style.MPL_LEGEND_SIZE)
    save(fig, "hopf.png")
# -

# The scheme moves the onset. The paper's scheme multiplies the mode of $\lambda$ by
# $1/(1 - \lambda\Delta t)$, which damps a vibration of frequency $\omega$ by about
# $\omega^2\Delta t/2$ (0.0175 here with $\Delta t = 0.001$); Crank–Nicolson's
# $(1 + \lambda\Delta t/2)/(1 - \lambda\Delta t/2)$ keeps $|z| > 1$ exactly where
# $\operatorname{Re}\lambda > 0$. Just below the onset, at $\zeta = 0.018$, the two schemes
# disagree as their step rates $\mu$ say:

# +
def onset_of(rate, lo: float = 0.005, hi: float = 0.04, steps: int = 30) -> float:
    """The ζ where rate(second vibration's λ) crosses 0, by bisection."""
    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if rate(vibration(rightmost(mid)[1], 4.0, 8.0)) > 0 else (lo, mid)
    return lo


paper_onset = onset_of(lambda lam: barber.step_rate(lam, DT).real)
say(f"onset with the paper's scheme, dt = {DT}: zeta = {paper_onset:.5f} "
    "(Crank-Nicolson: that of Re lambda)")
near_state, near_eigenvalues = rightmost(0.018)
for scheme in ("paper", "crank-nicolson"):
    mu = barber.step_rate(near_eigenvalues[0], DT, scheme)
    P = 2 * math.pi / mu.imag
    near = barber.run("barber", [*HOPF, "model.zeta=0.018", f"time.scheme={scheme}",
                                 "time.end=200", *barber.at_rest(near_state, "1e-4*x")])
    distance = near.u_1 - near_state.u_1
    rate = barber.decay_rate(near.t, distance, (100, 100 + P), (100 + 90 * P, 100 + 91 * P))
    say(f"{scheme:15s} Re lambda = {near_eigenvalues[0].real:.5f}: the run's rate {rate:.5f} "
        f"(Re mu = {mu.real:.5f}), period {barber.period(near.t, distance, 100, 200):.5f} "
        f"(2 pi/Im mu = {P:.5f})")
# -

# Above the bifurcation ($\zeta = 0.03$) a run from the uniformly hot rod, which flies into the
# obstacle, settles; below it ($\zeta = 0.01$) a run started at the steady state with a
# velocity of $10^{-5}x$ leaves it with the critical pair's period $2\pi/\operatorname{Im}\mu$
# at the rate $\operatorname{Re}\mu$, then settles into periodic intermittent contact, the end
# touching and leaving the obstacle once a period.

# +
stable_state, stable_eigenvalues = rightmost(0.03)
settled = barber.run("barber", [*HOPF, "model.zeta=0.03", "time.end=100"])
say(f"zeta = 0.03 from the hot rod, t = 100: u(1) - u* = {settled.u_1[-1] - stable_state.u_1:.2e}"
    f" (growth rate {stable_eigenvalues[0].real:.4f})")

end = 130 if SHORT else 160
run = barber.run("barber", [*HOPF, "model.zeta=0.01", f"time.end={end}",
                            *barber.at_rest(state, "1e-5*x")])
mu = barber.step_rate(eigenvalues[0], DT)
distance = run.u_1 - state.u_1
P = 2 * math.pi / mu.imag
growth = barber.decay_rate(run.t, distance, (20, 20 + P), (20 + 20 * P, 20 + 21 * P))
say(f"small oscillations (20 <= t <= 45): period {barber.period(run.t, distance, 20, 45):.5f} "
    f"(predicted {P:.5f}), growth {growth:.4f} (predicted {mu.real:.4f})")
cycle = barber.cycle(run, end - 30)
say(f"the cycle (t >= {end - 30}): period {barber.period(run.t, distance, end - 30, end):.4f}, "
    f"{cycle.touches} touches, in contact {100 * cycle.contact_fraction:.0f} % of the time, "
    f"u(1) from {cycle.u_min:.4f} to {cycle.u_max:.4f} (gap 0.11)")

with style.mpl_fonts():
    fig = Figure(figsize=style.MPL_SIZE)
    top, bottom = fig.subplots(2, 1)
    top.semilogy(run.t, np.abs(distance), color=style.colour(0), linewidth=0.5,
                 label="|u(1) − u*|")
    t = np.linspace(20, 45, 2)
    anchor = barber.envelope(run.t, distance, 20, 20 + P)
    top.semilogy(t, anchor * np.exp(mu.real * (t - 20)), "k--", label=f"e^(Re μ t), Re μ = "
                 f"{mu.real:.3f}")
    top.set_xlabel("t")
    top.legend(fontsize=style.MPL_LEGEND_SIZE)
    top.set_title("Leaving the unstable state (ζ = 0.01), then a cycle")
    late = run.t >= end - 5
    bottom.plot(run.t[late], run.u_1[late], color=style.colour(0), label="u(1)")
    bottom.axhline(0.11, color="0.6", linestyle="--", label="gap g")
    right = bottom.twinx()
    right.plot(run.t[late], run.p[late], color=style.colour(1), label="contact force p")
    bottom.set_xlabel("t")
    bottom.set_ylabel("u(1)")
    right.set_ylabel("p")
    bottom.legend(loc="upper left", fontsize=style.MPL_LEGEND_SIZE)
    right.legend(loc="upper right", fontsize=style.MPL_LEGEND_SIZE)
    save(fig, "intermittent_contact.png")
# -

# How the cycle grows with the distance from onset: from each state, kicked with $10^{-2}x$
# (near the cycle), the cycle reached by $t = 250$. Near onset it is small and stays pressed,
# its amplitude growing as $\sqrt{\operatorname{Re}\mu}$ and its period off the critical
# pair's by the amplitude squared (a supercritical Hopf bifurcation); once the amplitude
# exceeds $\varepsilon p$ the end leaves the obstacle once a period.

# +
say(f"{'zeta':>6} {'Re mu':>7} {'2 pi/Im mu':>10} {'period':>8} {'max|u-u*|':>10} {'contact':>8}")
for zeta in (0.016, 0.015, 0.012, 0.01):
    cycle_state, cycle_eigenvalues = rightmost(zeta)
    mu = barber.step_rate(cycle_eigenvalues[0], DT)
    grown = barber.run("barber", [*HOPF, f"model.zeta={zeta}", "time.end=300",
                                  *barber.at_rest(cycle_state, "1e-2*x")])
    distance = grown.u_1 - cycle_state.u_1
    window = barber.cycle(grown, 250)
    say(f"{zeta:6.3f} {mu.real:7.4f} {2 * math.pi / mu.imag:10.5f} "
        f"{barber.period(grown.t, distance, 250, 300):8.5f} "
        f"{barber.envelope(grown.t, distance, 250, 300):10.2e} "
        f"{100 * window.contact_fraction:7.0f}%")
# -

# From another start, the uniformly hot rod flying into the obstacle, the first vibration is
# excited as well. It decays slowly at this $\zeta$ (its growth rate is $-0.046$): the rod bounces
# with a period near 2.8 for a hundred time units, then settles into the same cycle.

# +
far = barber.run("barber", [*HOPF, "model.zeta=0.01", "time.end=300"])
distance = far.u_1 - state.u_1
for start in (0, 250):
    window = barber.cycle(far, start, start + 50)
    say(f"from the hot rod, {start} <= t <= {start + 50}: period "
        f"{barber.period(far.t, distance, start, start + 50):.4f}, {window.touches} touches, "
        f"u(1) from {window.u_min:.4f} to {window.u_max:.4f}")
# -

# The periodic contact is what Barber and Zhang (1988) found for rods in thermoelastic contact.
# Here it comes from the rod's second vibration made unstable by the exchange (without inertia
# the state is stable): its period near onset is $2\pi/\operatorname{Im}\lambda \approx 1.06$,
# and the finite cycle's, far below onset, about 5 % longer.

# ## The cycle found directly, and its stability
#
# `rodfem periodic` finds the cycle as what it is: a fixed point of the scheme's map over one
# period, $P_T(x) = x$ with the phase fixed by $u(1) = u^*$, solved by Newton's method on the
# state and the period, each shot $N$ steps of $\Delta t = T/N$ of the scene's own scheme. Its
# Floquet multipliers (the eigenvalues of the map's Jacobian) say whether it attracts: it does
# where every one but the trivial one (≈ 1, along the orbit) lies inside the unit circle. Beside
# it, the long run's last period, which settled on the same cycle from the hot rod.

# +
found = periodic.analyse("barber", [*HOPF, "model.zeta=0.01"], COMM)
orbit = found.orbit
late = far.t >= far.t[-1] - 50
measured = barber.period(far.t[late], far.u_1[late] - found.u_star, far.t[late][0],
                         far.t[-1])
say(f"shooting: period {orbit.period:.6f} (the long run's {measured:.6f}), "
    f"u(1) from {orbit.u_min:.5f} to {orbit.u_max:.5f}, in contact "
    f"{100 * orbit.contact_fraction:.1f}% of it; Newton's residual {orbit.residual:.1e}")
say(f"multipliers: the largest non-trivial |mu| = {abs(orbit.multipliers[0]):.4f} "
    f"(+- {orbit.multiplier_error:.1e}): {'stable' if orbit.stable else 'not stable'}")

with style.mpl_fonts():
    fig = Figure(figsize=style.MPL_SIZE)
    top, bottom = fig.subplots(2, 1, sharex=True)
    cycle = found.trace
    last = far.t >= far.t[-1] - orbit.period
    crossings = barber.upward_crossings(far.t[last], far.u_1[last] - found.u_star)
    shift = crossings[0] if crossings.size else far.t[last][0]
    top.plot(cycle["t"], cycle["u_1"], color=style.colour(0), linewidth=3, label="orbit found")
    top.plot(far.t[last] - shift, far.u_1[last], "k--", label="long run's last period")
    top.axhline(0.11, color="0.6", linestyle=":", label="gap g")
    bottom.plot(cycle["t"], cycle["p"], color=style.colour(1), linewidth=3)
    bottom.plot(far.t[last] - shift, far.p[last], "k--")
    top.set_ylabel("u(1)")
    bottom.set_ylabel("contact force p")
    bottom.set_xlabel("t (from the crossing of u*)")
    top.set_xlim(0, orbit.period)
    top.legend(fontsize=style.MPL_LEGEND_SIZE)
    top.set_title(f"The cycle at ζ = 0.01: period {orbit.period:.4f}")
    save(fig, "periodic_orbit.png")
# -
