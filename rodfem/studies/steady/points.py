r"""The stability along branches of steady states, the Hopf points on them, and the continuum's
values of growth rates and Hopf points, extrapolated in h.

Along a branch (:mod:`.continuation`) every point's state gets its spectrum
(:mod:`rodfem.solver.spectrum`), and two test functions are read from it:

* the growth rate (the largest real part), whose sign is the stability;
* ψ, the largest real part of the eigenvalues off the real axis (|Im λ| > :data:`COMPLEX` |λ|):
  where it changes sign between two points, a complex pair crosses the imaginary axis, a
  **Hopf point**. It is located on the branch between them by Brent's method on ψ along the
  chord, each trial point put back on the branch, to the doubles' resolution; its eigenvalue is
  then ±iω, and the oscillation born there has the period 2π/ω. A change of sign that is a jump
  of ψ (a pair of real eigenvalues meeting and leaving the axis), not a crossing, is no Hopf
  point: ψ at the point found must vanish to :data:`CROSSING` of |λ|.

A state's spectrum is the mesh's, not the rod's: P1 elements move its eigenvalues by O(h²).
With ``extrapolate`` each growth rate and each Hopf point is computed again on meshes of 2 and 4
times the cells, and Richardson's extrapolation in h² gives the continuum's value where the
three agree with order 2 (:mod:`rodfem.studies.asymptotic`'s band), with an error estimate: the
difference between the extrapolations from the two coarser and the two finer pairs. Outside the
band the value is flagged pre-asymptotic and not extrapolated.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from rodfem.studies import asymptotic
from rodfem.studies.steady import continuation as ct

# points.csv: the points of a diagram, a row each
POINTS = "points.csv"
POINT_COLUMNS = ("kind", "parameter", "u_1", "theta_1", "p", "sigma_1", "branch", "turns",
                 "before", "after", "omega", "period", "growth_rate", "parameter_continuum",
                 "parameter_error", "period_continuum", "period_error", "asymptotic", "key",
                 "lyapunov", "lyapunov_error", "criticality")

# An eigenvalue is off the real axis where |Im λ| exceeds this × |λ| (a cluster of nearly equal
# real ones, the Kelvin–Voigt rod's short waves near −1/ζ, splits by round-off far below it).
COMPLEX = 1e-6
# ψ at a located Hopf point must vanish to this × |λ|: a change of sign by a jump is no crossing.
CROSSING = 1e-6
REFINED = (2, 4)  # the meshes of an extrapolation: these times the scene's cells
COUNT = 12  # eigenvalues taken on the sparse path


def psi(eigenvalues: np.ndarray) -> tuple[float, complex | None]:
    """The Hopf test function: the largest real part among the eigenvalues off the real axis,
    and that eigenvalue (with Im > 0); (−inf, None) where there is none."""
    off = eigenvalues[np.abs(eigenvalues.imag) > COMPLEX * np.abs(eigenvalues)]
    off = off[off.imag > 0.0]
    if not off.size:
        return -math.inf, None
    top = off[int(np.argmax(off.real))]
    return float(top.real), complex(top)


def eigenvalues(spectra, scene, lin) -> np.ndarray:
    """A state's eigenvalues, largest real part first: every finite one by QZ on a mesh the
    spectra take dense, the rightmost :data:`COUNT` on the sparse path (every one right of the
    imaginary axis among them, which is what ψ's sign needs)."""
    if spectra.dense(scene):
        return spectra.eigenvalues(scene, lin)
    return spectra.rightmost(scene, lin, COUNT).values


@dataclasses.dataclass(frozen=True)
class Hopf:
    """A located Hopf point: its point on the branch and the crossing pair's ω."""

    point: ct.Point
    omega: float
    rate: float = 0.0  # the pair's real part there, at round-off


class Spectral:
    """The spectra of the states of one :class:`~.continuation.Curve` (at the scene's mesh, or
    ``cells`` of it)."""

    def __init__(self, curve: ct.Curve, spectra, cells: int | None = None):
        self.curve, self.spectra = curve, spectra
        self.cells = cells

    def scene_at(self, value: float):
        scene = self.curve.scene_at(value)
        return scene if self.cells is None else ct.at(scene, "mesh.cells", self.cells)

    def state(self, point: ct.Point):
        problem = self.curve.problem(point.value)
        state = problem.state(point.t, point.kind == "fold")
        return problem, state

    def eigenvalues(self, point: ct.Point) -> np.ndarray:
        problem, state = self.state(point)
        return eigenvalues(self.spectra, self.scene_at(point.value), problem.linearise(state))

    def test(self, point: ct.Point) -> float:
        return psi(self.eigenvalues(point))[0]

    def hopf(self, before: ct.Point, after: ct.Point) -> Hopf | None:
        """The Hopf point between two points of a branch where ψ changes sign (None: it does
        not, or by a jump)."""
        import scipy.optimize

        curve = self.curve
        x0, x1 = curve.scaled(before.t, before.value), curve.scaled(after.t, after.value)
        chord = x1 - x0
        length = float(np.hypot(*chord))
        if length == 0.0:
            return None
        normal = np.array([-chord[1], chord[0]]) / length

        def on_branch(share: float) -> ct.Point:
            if share <= 0.0:
                return before
            if share >= 1.0:
                return after
            found = curve.on_line(x0 + share * chord, normal, length)
            if found is None:
                raise ct.ContinuationError("a Hopf point's trial point left the branch")
            t, value = curve.unscaled(found)
            return ct.Point(t, value)

        f0, f1 = self.test(before), self.test(after)
        if not (math.isfinite(f0) and math.isfinite(f1)) or (f0 < 0.0) == (f1 < 0.0):
            return None
        share = scipy.optimize.brentq(lambda s: self.test(on_branch(s)), 0.0, 1.0,
                                      xtol=1e-15, rtol=4 * ct.EPS, maxiter=200)
        point = on_branch(share)
        rate, pair = psi(self.eigenvalues(point))
        if pair is None or abs(rate) > CROSSING * abs(pair):
            return None
        return Hopf(ct.Point(point.t, point.value, "hopf"), pair.imag, rate)

    def lyapunov(self, hopf: Hopf):
        """The first Lyapunov coefficient at a located Hopf point
        (:mod:`rodfem.solver.lyapunov`, q normalised by u(1)): a
        :class:`~rodfem.solver.lyapunov.Lyapunov`, unknown where the rigid obstacle holds the
        end or a law gives no derivatives of third order."""
        from rodfem.model.expansion import expand
        from rodfem.solver import banded
        from rodfem.solver import lyapunov as ly

        problem, state = self.state(hopf.point)
        scene = self.scene_at(hopf.point.value)
        try:
            expansion = expand(problem, state)
        except NotImplementedError:
            return ly.UNKNOWN
        lin = problem.linearise(state)
        a, b, zeta = scene["model.a"], scene["model.b"], scene["model.zeta"]
        dense = self.spectra.dense(scene)
        if dense:
            A, M = self.spectra.pencil(scene, lin)
        else:
            A, M = banded.pencil(self.spectra.sparse_operators(scene), a, b, zeta, lin)
        n = A.shape[0] // 3
        if not (np.all(np.isfinite(np.asarray(A.data if not dense else A)))):
            return ly.UNKNOWN
        try:
            return ly.of_rod(A, M, complex(hopf.rate, hopf.omega), expansion, n, not dense)
        except (ValueError, RuntimeError):
            return ly.UNKNOWN


@dataclasses.dataclass(frozen=True)
class Continuum:
    """A value computed on the scene's mesh and on 2 and 4 times its cells, extrapolated in h²:
    ``value`` (nan where pre-asymptotic), ``error`` its estimate, ``order`` the observed one,
    ``asymptotic`` whether it lies in the band about 2."""

    values: tuple[float, float, float]
    value: float
    error: float
    order: float
    asymptotic: bool


def extrapolated(values) -> Continuum:
    """Richardson's extrapolation of three values on meshes refined by 2, in h² (the module's
    doc): the continuum's value and the estimate of its error."""
    m0, m1, m2 = (float(v) for v in values)
    d1, d2 = m1 - m0, m2 - m1
    with np.errstate(divide="ignore", invalid="ignore"):
        order = math.log2(d1 / d2) if d1 != 0.0 and d2 != 0.0 and d1 / d2 > 0.0 else math.nan
    expect = float(asymptotic.SPACE_ORDER)
    if d2 == 0.0 and d1 == 0.0:  # the same on every mesh (a state's exact growth rate)
        return Continuum((m0, m1, m2), m2, 0.0, math.nan, True)
    inside = asymptotic.within(order, expect)
    finer = m2 + asymptotic.estimate([m0, m1, m2], expect)
    coarser = m1 + asymptotic.estimate([m0, m1], expect)
    if not inside:
        return Continuum((m0, m1, m2), math.nan, abs(d2), order, False)
    return Continuum((m0, m1, m2), finer, abs(finer - coarser), order, True)
