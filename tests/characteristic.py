r"""The exact characteristic equation of the continuous problem linearised about a steady state:
a test oracle for the growth rates and Hopf points of rodfem.solver.spectrum, sharing no code
with its discretisation (only a scene's values and a state's Linearisation are read from rodfem).

**The linearised problem.** About a steady state, perturbations θ̃, ũ, ṽ = ũ_t obey (the weak
form of rodfem.solver.spectrum integrated by parts; θ̃ perturbs the temperature θ = Θ + L and the
shifted Θ alike, the lifting L being fixed)

    θ̃_t = θ̃_xx − a ṽ_x,                        θ̃(0) = 0,  −θ̃_x(1) = h θ̃(1) + c_u ũ(1) + c_p p̃,
    b ṽ_t = σ̃_x,  σ̃ = ũ_x + ζ ṽ_x − a θ̃,       ũ(0) = 0,  σ̃(1) = −κ ũ(1),

h the exchange coefficient at the state, κ = dp/du(1) (0 apart), c_u and c_p the exchange
flux's change h(θ(1) − θ_O) with u(1) and with the contact force (Linearisation's exchange_u and
exchange_p); against the rigid obstacle in contact (``held``) the second condition at x = 1 is
ũ(1) = 0 and p̃ = −σ̃(1) is its reaction (c_u then multiplies ũ(1) = 0; c_p is 0 otherwise).

**The ODE in x.** With e^{λt}: λθ̃ = θ̃'' − aλũ', bλ²ũ = σ̃', σ̃ = z ũ' − aθ̃, z = 1 + ζλ. For
y = (θ̃, θ̃', ũ, σ̃) this is y' = A(λ) y,

    A(λ) = [[0, 1, 0, 0], [λ(1 + a²/z), 0, 0, aλ/z], [a/z, 0, 0, 1/z], [0, 0, bλ², 0]],

whose eigenvalues are ±r₁, ±r₂, r_j² = μ_j the roots of the quadratic

    z μ² − (λ(z + a²) + bλ²) μ + bλ³ = 0

(the (θ̃, σ̃) system θ̃'' = λ(1 + a²/z)θ̃ + (aλ/z)σ̃, σ̃'' = (bλ²/z)(σ̃ + aθ̃)): the heat root
μ ≈ λ and the elastic one μ ≈ bλ²/z. With the fundamental matrix Φ(x) = exp(x A), the four
conditions are B(λ) c = 0 for y = Φ c,

    B(λ) = [[e₁ᵀ], [e₃ᵀ], [R Φ(1)]],   R = [[h, 1, c_u, 0], [0, 0, κ, 1]]
    (held: R = [[h, 1, 0, −c_p], [0, 0, 1, 0]]),

and **the eigenvalues are the roots of D(λ) = det B(λ)** (analytic but for a pole at z = 0, the
Kelvin–Voigt accumulation point λ = −1/ζ).

**Without overflow or cancellation.** Φ(1) grows as e^{max Re r}, and its two columns that meet
the conditions at x = 0 both lean towards the fastest mode: det R Φ(1)[:, (2, 4)] cancels
e^{|Re(r₁ − r₂)|} (e^{31} for the rigid obstacle's 5713 below, e^{444} for ζ = 0's 466). In
the eigenbasis v_k, ν_k of A, each mode is written from the end where it is largest,
w_k(x) = v_k e^{ν_k(x − x_k)}, x_k = 1 if Re ν_k > 0 else 0; every entry of the boundary matrix N of these w_k is O(1), and since
w = Φ V diag(e^{−ν_k x_k}),

    D(λ) = det N / det V · exp(Σ_{Re ν_k > 0} ν_k),

whatever the order, scaling or branch of the ν_k (exactly: the formula holds for any basis, so
D is continuous across Re ν = 0). D is carried as the pair (mantissa, exponent). Where two ν_k
come close (the heat and elastic roots cross near λ ≈ 1/(b − ζ), and λ → 0) V is ill
conditioned and the modes mix little: there D = e^{2ρ} det[[e₁ᵀ], [e₃ᵀ], [R exp(A − ρ)]],
ρ = max Re ν_k, from SciPy's expm. The two forms agree where both apply (tested), and against
mpmath's expm at 250 digits with no scaling at all.

Roots: Newton on D e^{−(r₁ + r₂)} (its exponential growth taken out), the derivative from
central differences of ratios (never overflowing), to |Δλ| ≤ 1e-13 |λ|; :func:`count` counts
them in a box by the argument principle. A Hopf point: the ζ where Re λ(ζ) = 0 for the pair
followed from a guess, by Brent's method in ζ (each evaluation a Newton solve from the last λ).

**Values found** (tests/test_characteristic.py checks each; `barber` with the overrides shown,
the states rodfem.model.steady's; FOUND below holds them to the last digit):

* The hot rod of docs/barber.md (`model.theta_A=10 initial.theta0=10 obstacle.temperature=0
  heat_exchange.k1=1000 heat_exchange.exponent=2 obstacle.gap=0.11 obstacle.epsilon=0.1`: one
  steady state, u(1) = 0.112373, p = 0.023732, h = 0.66322, κ = 10, c_u = 2853.78). Its second
  vibration's pair crosses the imaginary axis at **ζ = 0.01837100717558, ω = 5.916770544714,
  period 2π/ω = 1.061928168364** (an earlier independent check: 0.018371, 5.91677, 1.06193). At
  ζ = 0.01 the rightmost pair is 0.1290554923 ± 5.9024430216i, then the first vibration
  −0.0456131216 ± 2.5096780794i; the argument principle counts 10 roots in
  [−1, 10] × [−16i, 16i], the 10 Newton finds from rodfem's eigenvalues.
* `obstacle.kind=rigid` (k₁ = 1000, ζ = 0.5), the middle (unstable) state: **λ = 5713.307515129**
  (rodfem: 4875.58 / 5450.75 / 5642.89 at 100 / 200 / 400 cells; the eigenfunction's boundary
  layer at x = 1, elastic root r ≈ √(bλ/ζ) ≈ 107, is resolved only where h r ≪ 1).
* `model.zeta=0`, the middle state: **λ = 465.6666376115** (rodfem: 305.37 / 375.10 / 427.68 at
  100 / 200 / 400 cells; r ≈ λ√b ≈ 466). A P1 pencil on 4000 / 8000 / 16000 cells, extrapolated,
  gives both to 1e-6. The same scene's separated state: the fundamental −4.7768e-5 ± 1.5708210i
  is the exact rightmost root; the discrete growth rate (−1.44e-5 at 100 cells, −1.02e-5 at
  200) is the mesh's shortest wave, which the continuous problem damps more (−1.7e-4 near
  ω = 58).
* `barber` itself: separated −0.6169198856 ± 1.4446204414i, unstable 94.27451220, pressed: the
  Kelvin–Voigt roots −2.2585345046, −2.5412104621 ± 1.9857374297i, … accumulate at −1/ζ = −2
  from below; the discrete growth rate (−2.0002 at 100 cells) is the mesh's shortest such wave,
  tending to −2 as h².
* `obstacle.kind=rigid heat_exchange.k1=60`: 13.10504763336 (docs/thermal-contact.md's
  13.105047633).
"""

from __future__ import annotations

import cmath
import dataclasses
import math

import numpy as np
import scipy.linalg
import scipy.optimize

# Modes closer than this (relative to the largest |ν|) are taken together by expm.
CLOSE = 0.05
# Newton: the step at which a root is taken as converged (relative to max(|λ|, 1)).
STEP = 1e-13


@dataclasses.dataclass(frozen=True)
class Params:
    """The linearised problem's numbers: the model's a, b, ζ and the state's h, κ, c_u, c_p,
    held (rodfem.model.steady.Linearisation)."""

    a: float
    b: float
    zeta: float
    h: float
    kappa: float
    c_u: float
    c_p: float
    held: bool

    def with_zeta(self, zeta: float) -> Params:
        return dataclasses.replace(self, zeta=float(zeta))


def params_of(scene, lin) -> Params:
    """The Params of a validated scene's model and a state's Linearisation."""
    return Params(a=scene["model.a"], b=scene["model.b"], zeta=scene["model.zeta"], h=lin.h,
                  kappa=lin.kappa, c_u=lin.exchange_u, c_p=lin.exchange_p, held=lin.held)


def system(lam: complex, p: Params) -> np.ndarray:
    """A(λ) of y' = A y, y = (θ̃, θ̃', ũ, σ̃)."""
    z = 1.0 + p.zeta * lam
    return np.array([[0, 1, 0, 0],
                     [lam * (1.0 + p.a * p.a / z), 0, 0, p.a * lam / z],
                     [p.a / z, 0, 0, 1.0 / z],
                     [0, 0, p.b * lam * lam, 0]], dtype=complex)


def conditions(p: Params) -> np.ndarray:
    """R: the two conditions at x = 1 on y(1)."""
    if p.held:
        return np.array([[p.h, 1.0, 0.0, -p.c_p], [0.0, 0.0, 1.0, 0.0]], dtype=complex)
    return np.array([[p.h, 1.0, p.c_u, 0.0], [0.0, 0.0, p.kappa, 1.0]], dtype=complex)


def _start() -> np.ndarray:
    """The two conditions at x = 0: θ̃(0) = ũ(0) = 0."""
    return np.array([[1, 0, 0, 0], [0, 0, 1, 0]], dtype=complex)


def modes(lam: complex, p: Params) -> tuple[np.ndarray, np.ndarray]:
    """(ν, V): the eigenvalues ±r₁, ±r₂ of A(λ) and eigenvectors (columns), from the quadratic
    in μ = r² and M's eigenvectors (θ̃, σ̃), with θ̃' = νθ̃ and ũ = (σ̃ + aθ̃)/(zν)."""
    z = 1.0 + p.zeta * lam
    m11, m12 = lam * (1.0 + p.a * p.a / z), p.a * lam / z
    m21, m22 = p.b * lam * lam * p.a / z, p.b * lam * lam / z
    half, det = 0.5 * (m11 + m22), m11 * m22 - m12 * m21
    root = cmath.sqrt(0.25 * (m11 - m22) ** 2 + m12 * m21)
    big = half + root if abs(half + root) >= abs(half - root) else half - root
    mus = (big, det / big if big != 0 else half - root)
    nus, vectors = [], []
    for mu in mus:
        # M e = μ e, from the better of its two rows
        first, second = np.array([m12, mu - m11]), np.array([mu - m22, m21])
        e = first if np.linalg.norm(first) >= np.linalg.norm(second) else second
        e = e / np.linalg.norm(e)
        r = cmath.sqrt(mu)
        for nu in (r, -r):
            theta, sigma = e
            vectors.append([theta, nu * theta, (sigma + p.a * theta) / (z * nu), sigma])
            nus.append(nu)
    return np.array(nus), np.array(vectors, dtype=complex).T


def _separated(nus: np.ndarray) -> bool:
    """Whether the four ν_k lie apart enough for the eigenbasis."""
    scale = max(float(np.max(np.abs(nus))), 1e-300)
    gaps = [abs(nus[i] - nus[j]) for i in range(4) for j in range(i + 1, 4)]
    return min(gaps) > CLOSE * scale


def determinant(lam: complex, p: Params, form: str = "auto") -> tuple[complex, complex]:
    """D(λ) = mantissa · exp(exponent): the pair (mantissa, exponent). ``form``: "modes" (the
    eigenbasis, each mode from the end where it is largest), "expm" (exp(A − ρ), ρ = max Re ν)
    or "auto" (modes unless two ν_k come close)."""
    lam = complex(lam)
    A, R = system(lam, p), conditions(p)
    nus, V = modes(lam, p)
    if form == "auto":
        form = "modes" if _separated(nus) else "expm"
    if form == "modes":
        growing = nus.real > 0.0
        at0, at1 = np.ones(4, dtype=complex), np.ones(4, dtype=complex)
        at0[growing], at1[~growing] = np.exp(-nus[growing]), np.exp(nus[~growing])
        N = np.vstack([_start() @ V * at0, R @ V * at1])
        return np.linalg.det(N) / np.linalg.det(V), complex(np.sum(nus[growing]))
    rho = float(np.max(nus.real))
    Phi = scipy.linalg.expm(A - rho * np.eye(4))
    return np.linalg.det(np.vstack([_start(), R @ Phi])), complex(2.0 * rho)


def D(lam: complex, p: Params, form: str = "auto") -> complex:
    """D(λ) itself (may overflow for large |λ|: the roots use the pair)."""
    mantissa, exponent = determinant(lam, p, form)
    return mantissa * cmath.exp(exponent)


def log_ratio(lam: complex, base: complex, p: Params) -> complex:
    """log(D(λ)/D(base)), the principal value (its imaginary part in (−π, π]): near 0 for λ
    near base (no overflow; the exponents' imaginary parts, sums of ν_k, are not reduced)."""
    m1, e1 = determinant(lam, p)
    m0, e0 = determinant(base, p)
    value = cmath.log(m1 / m0) + (e1 - e0)
    return complex(value.real, math.remainder(value.imag, 2.0 * math.pi))


class NoRoot(RuntimeError):
    """Newton did not converge from the guess."""


def _growth(lam: complex, p: Params, reference: complex) -> complex:
    """s(λ) = r₁ + r₂, the growing ν_k at ``reference`` continued to λ (each the nearest ν at
    λ): D(λ) e^{−s(λ)} varies slowly where D grows as e^{r₁ + r₂}, and s is analytic near
    ``reference`` (symmetric in the two modes, so their crossing is no branch point)."""
    here, _ = modes(reference, p)
    there, _ = modes(lam, p)
    return complex(sum(there[np.argmin(np.abs(there - nu))] for nu in here if nu.real > 0.0))


def root(guess: complex, p: Params, maxiter: int = 60) -> complex:
    """The root of D near ``guess``, by Newton's method on f = D e^{−s} (s: :func:`_growth`,
    so that the step is not ruled by D's exponential growth), to |Δλ| ≤ 1e-13 max(|λ|, 1)."""
    try:
        with np.errstate(all="ignore"):
            return _newton(complex(guess), p, maxiter)
    except (ValueError, ZeroDivisionError, OverflowError, np.linalg.LinAlgError) as error:
        raise NoRoot(f"Newton from {guess}: {error}") from error


def _newton(lam: complex, p: Params, maxiter: int) -> complex:
    guess = lam
    for _ in range(maxiter):
        scale = max(abs(lam), 1.0)
        delta = 1e-6 * scale
        # f'/f from f(λ ± δ)/f(λ): ratios, never overflowing, and no branch of log to cross
        if determinant(lam, p)[0] == 0:
            return lam  # D vanishes here to the last bit
        s0 = _growth(lam, p, lam)
        ratios = [cmath.exp(log_ratio(lam + d, lam, p) - (_growth(lam + d, p, lam) - s0))
                  for d in (delta, -delta)]
        slope = (ratios[0] - ratios[1]) / (2 * delta)
        if not cmath.isfinite(slope) or slope == 0:
            raise NoRoot(f"Newton from {guess}: D' vanishes at {lam}")
        step = -1.0 / slope
        lam += step
        if not cmath.isfinite(lam):
            raise NoRoot(f"Newton from {guess}: diverged")
        if abs(step) <= STEP * scale:
            return lam
    raise NoRoot(f"Newton from {guess}: no convergence, last {lam}")


def rightmost(p: Params, guesses, count: int | None = None, reach: float = 0.5) -> np.ndarray:
    """The roots of D reached from ``guesses`` (rodfem's discrete eigenvalues, within O(h²),
    or a grid), distinct, largest real part first (of a pair, both: complex roots come in
    conjugate pairs as D is real on the real axis); the first ``count`` of them. A root
    further than ``reach`` × max(|guess|, 1) from its guess is not taken (Newton escaped)."""
    found: list[complex] = []
    for guess in guesses:
        try:
            lam = root(guess, p)
        except NoRoot:
            continue
        if abs(lam - guess) > reach * max(abs(guess), 1.0):
            continue
        for candidate in (lam, lam.conjugate()):
            if all(abs(candidate - f) > 1e-9 * max(abs(candidate), 1.0) for f in found):
                found.append(candidate)
    found.sort(key=lambda lam: (-lam.real, -lam.imag))
    return np.array(found[:count] if count else found)


def grid(re: tuple[float, float], im: tuple[float, float], n: int = 8) -> list[complex]:
    """n × n starting points on the box re × im of the λ plane."""
    return [complex(x, y) for x in np.linspace(*re, n) for y in np.linspace(*im, n)]


@dataclasses.dataclass(frozen=True)
class Hopf:
    """Where the followed pair crosses the imaginary axis: ζ, the frequency ω and the period."""

    zeta: float
    omega: float

    @property
    def period(self) -> float:
        return 2.0 * math.pi / self.omega


def hopf(params_of_zeta, zeta_lo: float, zeta_hi: float, guess: complex,
         xtol: float = 1e-15) -> Hopf:
    """The ζ in [zeta_lo, zeta_hi] where the root λ(ζ) followed from ``guess`` (an eigenvalue at
    zeta_lo) has Re λ = 0: Brent's method in ζ on Re λ(ζ), each λ(ζ) Newton's from the
    last one found (the pair is followed, not the rightmost one re-chosen)."""
    last = {"lam": root(guess, params_of_zeta(zeta_lo))}

    def real_part(zeta: float) -> float:
        last["lam"] = root(last["lam"], params_of_zeta(zeta))
        return last["lam"].real

    zeta = scipy.optimize.brentq(real_part, zeta_lo, zeta_hi, xtol=xtol, rtol=4 * np.finfo(
        float).eps)
    lam = root(last["lam"], params_of_zeta(zeta))
    return Hopf(zeta=float(zeta), omega=abs(lam.imag))


def count(p: Params, box: tuple[float, float, float, float], points: int = 4000) -> int:
    """The number of roots of D inside the rectangle (re₀, re₁, im₀, im₁) by the argument
    principle: the winding of D along its edge, from log(D(λ_{i+1})/D(λ_i)) between points
    close enough that each ratio's argument is small (checked). The box must hold no pole
    (λ = −1/ζ)."""
    r0, r1, i0, i1 = box
    corners = [complex(r0, i0), complex(r1, i0), complex(r1, i1), complex(r0, i1)]
    perimeter = 2 * ((r1 - r0) + (i1 - i0))
    path = []
    for k in range(4):
        start, end = corners[k], corners[(k + 1) % 4]
        n = max(8, int(points * abs(end - start) / perimeter))
        path.extend(start + (end - start) * t for t in np.arange(n) / n)
    path.append(path[0])
    winding = 0.0
    for left, right in zip(path, path[1:]):
        turn = log_ratio(right, left, p).imag
        if abs(turn) > 1.0:
            raise ValueError(f"the argument turns by {turn:.2f} between {left} and {right}: "
                             "more points")
        winding += turn
    return round(winding / (2 * math.pi))


# The exact values found (tests/test_characteristic.py recomputes them to 1e-12 relative).
FOUND = {
    "barber separated": -0.6169198855906994 + 1.4446204413634156j,
    "barber unstable": 94.27451220369643 + 0j,
    "barber pressed, isolated": -2.2585345046207963 + 0j,
    "barber pressed, pair": -2.5412104621217106 + 1.9857374297187231j,
    "hot rod, ζ = 0.01": 0.12905549232153765 + 5.902443021572995j,
    "hot rod, first vibration": -0.04561312162950273 + 2.509678079399533j,
    "rigid, unstable": 5713.307515128505 + 0j,
    "rigid, pair": -1.3688027801820475 + 2.031684150892923j,
    "rigid k1 = 60, unstable": 13.105047633363576 + 0j,
    "ζ = 0, unstable": 465.66663761149596 + 0j,
    "ζ = 0, pressed": 0.0018411023512475639 + 3.1361331302453537j,
    "ζ = 0, separated": -4.776750278167557e-05 + 1.5708209636208716j,
    "hot rod Hopf ζ": 0.0183710071755838,
    "hot rod Hopf ω": 5.916770544713504,
}
