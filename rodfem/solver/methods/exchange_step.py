"""The direct method's step with a heat exchange that depends on the contact: one scalar equation.

A variable law (:mod:`rodfem.model.exchange`) adds to the heat row of x = 1 the flux

    φ = q (Θⁿ⁻¹(1) + w_t ΔΘⁿ(1) + offset),   q = law.extra(exchange_place(y, c), p),

w_t the time scheme's weight, y = Uⁿ(1), c = Uⁿ⁻¹(1) and p the step's contact force. With C the
coupled operator, its response to a unit force q_c = C⁻¹[0; −e] and to a unit heat sink at the end
q_h = C⁻¹[−e; 0], both made once, the step is x = z + p q_c + φ q_h for the free step z = C⁻¹[h; m],
and everything the laws read is a scalar:

    y = s − w p + α φ,   T = T0 + w_t (β p + γ φ),   φ = q T,

s = c + z_U(1), w = −q_c,U(1) the compliance, α = q_h,U(1), β = q_c,Θ(1), γ = q_h,Θ(1) < 0,
T0 = Θⁿ⁻¹(1) + offset + w_t z_Θ(1), T = θ(1) − θ_O at the scheme's weight. For a given p and q,
T = (T0 + w_t β p)/(1 − w_t γ q) in closed form. The unknown is the free reach t = y + w p: for any
t the contact law's own solve gives p(t) and y(t) = t − w p(t) (today's step with s = t; the rigid
obstacle's multiplier included), both non-decreasing in t with Δy + w Δp = Δt, and the step is

    G(t) = t − s − α φ(t) = 0.

Without exchange (φ ≡ 0) t = s: today's step. The root is bracketed from t = s outwards, found to
round-off (regula falsi with the Illinois rule, bisection where it stalls) and shown to be the only
one in the bracket by one of two sufficient conditions (:meth:`ExchangeStep.unique`), else the step
fails (:class:`NoUniqueRoot`): a hot obstacle can make the step's equation have several roots
(heat that enters expands the rod, which presses harder and takes more heat).
"""

from __future__ import annotations

import math

MAX_ITERATIONS = 4000  # as rodfem.model.contact.law's monotone_root
MAX_DOUBLINGS = 2100  # enough to reach a double's range from any start


# What a step says where it is not shown to have one root (the compiled loop says the same)
NOT_UNIQUE = ("the step's equation for u(1) with the heat exchange may have several roots (heat "
              "that enters through the contact can push the end on as much as its motion holds "
              "it back); a smaller time.dt makes its root unique")


class NoUniqueRoot(ValueError):
    """The step's equation G(t) = 0 has no root shown to be unique: the detail says why."""


def bracketed_root(F, lo: float, hi: float, f_lo: float, f_hi: float) -> float:
    """A root of F in [lo, hi], F(lo) = f_lo < 0 < f_hi = F(hi), F continuous: regula falsi with
    the Illinois rule (the end kept twice running has its value halved), bisection where the
    secant would leave the bracket, until F vanishes or the bracket's ends are adjacent doubles.
    Returns whichever end has the smaller |F|. ``exchange.h``'s rx_root repeats it."""
    side, F_lo, F_hi = 0, f_lo, f_hi  # F_lo, F_hi: F at the ends (f_lo, f_hi: Illinois's)
    for _ in range(MAX_ITERATIONS):
        t = lo - f_lo * ((hi - lo) / (f_hi - f_lo))
        if not lo < t < hi:
            t = lo + 0.5 * (hi - lo)
        if not lo < t < hi:  # lo and hi are adjacent: nothing lies between
            break
        f = F(t)
        if f == 0.0:
            return t
        if f > 0.0:
            hi, f_hi, F_hi = t, f, f
            if side == 1:
                f_lo *= 0.5
            side = 1
        else:
            lo, f_lo, F_lo = t, f, f
            if side == -1:
                f_hi *= 0.5
            side = -1
    return lo if abs(F_lo) < abs(F_hi) else hi


class ExchangeStep:
    """The scalars of a method's step with a variable exchange (the module's docstring)."""

    def __init__(self, method, alpha: float, beta: float, gamma: float):
        self.exchange = method.exchange
        self.scheme = method.time_scheme
        self.law = method.law if method.massless is None else method.massless.law
        self.w, self.weight, self.offset = method.compliance, self.scheme.weight, method.offset
        self.alpha, self.beta, self.gamma = float(alpha), float(beta), float(gamma)
        if not self.gamma < 0.0:
            raise RuntimeError(f"the end's temperature response to its heat loss is "
                               f"{self.gamma:g}, not negative")

    def temperature(self, T0: float, p: float, q: float) -> float:
        """T = θ(1) − θ_O at the scheme's weight, for the force p and the exchange q."""
        return (T0 + self.weight * self.beta * p) / (1.0 - self.weight * self.gamma * q)

    def flux(self, y: float, c: float, p: float, T0: float) -> tuple[float, float]:
        """(q, φ) for Uⁿ(1) = y, Uⁿ⁻¹(1) = c and the force p."""
        q = self.exchange.extra(self.scheme.exchange_place(y, c), p)
        return q, (q * self.temperature(T0, p, q) if q != 0.0 else 0.0)

    def at(self, t: float, c: float, T0: float) -> tuple[float, float, float, float]:
        """(p, y, q, φ) of the free reach t: the contact law's force where y + w p(y) = t."""
        law, scheme = self.law, self.scheme
        p = scheme.contact_solve(law, t, self.w, c) if scheme.contact_needed(law, t, c) else 0.0
        y = t - self.w * p
        return (p, y, *self.flux(y, c, p, T0))

    def solve(self, s: float, c: float, T0: float) -> tuple[float, float]:
        """The step's (p, φ), from s = c + z_U(1), c = Uⁿ⁻¹(1) and T0. NoUniqueRoot where the
        root is not shown to be unique in its bracket."""
        alpha, known = self.alpha, {}  # known: at(t) of each t evaluated

        def at(t: float) -> tuple[float, float, float, float]:
            if t not in known:
                known[t] = self.at(t, c, T0)
            return known[t]

        def G(t: float) -> float:
            return t - s - alpha * at(t)[3]

        f = G(s)
        if f == 0.0:  # no exchange at s (or α = 0): today's step
            p, _, _, phi = at(s)
            return p, phi
        # G(t) ≥ t − s − |α φ(t)|: step away from s, doubling, until G changes sign
        direction = 1.0 if f < 0.0 else -1.0
        width, near, f_near = abs(f), s, f
        for _ in range(MAX_DOUBLINGS):
            far = s + direction * width
            f_far = G(far)
            if not (math.isfinite(far) and math.isfinite(f_far)):
                break
            if (f_far >= 0.0) if direction > 0.0 else (f_far <= 0.0):
                break
            near, f_near, width = far, f_far, 2.0 * width
        else:
            f_far = math.nan
        if not (math.isfinite(far) and math.isfinite(f_far)):
            raise NoUniqueRoot("no root of the step's equation found from the end's free "
                               f"position {s:g}")
        lo, hi, f_lo, f_hi = (near, far, f_near, f_far) if direction > 0.0 else \
            (far, near, f_far, f_near)
        self.unique(at(lo), at(hi), c, T0)
        t = hi if f_hi == 0.0 else lo if f_lo == 0.0 else bracketed_root(G, lo, hi, f_lo, f_hi)
        p, _, _, phi = at(t)
        return p, phi

    def unique(self, lo: tuple, hi: tuple, c: float, T0: float) -> None:
        """Show that G has one root in the bracket whose ends have :meth:`at` ``lo`` and ``hi``,
        or raise NoUniqueRoot.

        φ = N(p) g(q) with N = T0 + w_t β p affine and g(q) = q/(1 − w_t γ q) increasing, and p, q
        non-decreasing in t. (1) Where N keeps a sign with αN ≤ 0 and βN ≥ 0, αφ is
        non-increasing and G strictly increasing. (2) Else, for t₁ < t₂ with Δy + w Δp = Δt,
        |α Δφ| ≤ c_y Δy + c_p Δp with c_y = |α| N̂ w_t L_y and c_p = |α| (N̂ L_p + ĝ w_t |β|), N̂
        and ĝ the largest |N| and g on the bracket and L_y, L_p bounds of q's partial
        derivatives there; so ΔG ≥ (1 − c_y) Δy + (w − c_p) Δp, and with Δp ≤ S Δy, S a bound
        of the contact force's slope (:meth:`force_slope`), G increases if 1 − c_y > 0 and
        w − c_p > 0, or 1 − c_y + (w − c_p) S > 0."""
        (p_lo, y_lo, _, _), (p_hi, y_hi, q_hi, _) = lo, hi
        alpha, beta, weight = self.alpha, self.beta, self.weight
        N_lo, N_hi = T0 + weight * beta * p_lo, T0 + weight * beta * p_hi
        if N_lo >= 0.0 and N_hi >= 0.0 and alpha <= 0.0 and beta >= 0.0:
            return
        if N_lo <= 0.0 and N_hi <= 0.0 and alpha >= 0.0 and beta <= 0.0:
            return
        place = self.scheme.exchange_place
        L_y, L_p = self.exchange.extra_slope_bounds(place(y_lo, c), place(y_hi, c), p_lo, p_hi)
        g_hi = q_hi / (1.0 - weight * self.gamma * q_hi)
        N_max = max(abs(N_lo), abs(N_hi))
        c_y = abs(alpha) * N_max * weight * L_y
        c_p = abs(alpha) * (N_max * L_p + g_hi * weight * abs(beta))
        margin = 1.0 - c_y
        if not self.w - c_p > 0.0:
            margin += (self.w - c_p) * self.force_slope(y_hi, c)
        if not margin > 0.0:
            raise NoUniqueRoot(NOT_UNIQUE)

    def force_slope(self, y_hi: float, c: float) -> float:
        """A bound of the step's contact force's slope in y = Uⁿ(1) up to y_hi: φ''(y_hi), and
        for Crank–Nicolson's discrete gradient from c φ''(max(y_hi, c)) (φ'' non-decreasing:
        the linear law and the power law with exponent ≥ 1); infinite for the rigid obstacle."""
        law = self.law
        if law.rigid:
            return math.inf
        return law.slope(max(y_hi, c) if self.scheme.gradient_contact else y_hi)
