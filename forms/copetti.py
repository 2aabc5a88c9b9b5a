"""Copetti's fully discrete scheme (3.1)–(3.4) as UFL forms.

The rod is I = (0, 1) with P1 elements; S_E holds the P1 functions that vanish at x = 0. The
unknowns are the shifted temperature Θ = θ + θ_A r, r(x) = c x − 1, c = k/(k + 1) (Remark 2.2),
and the displacement U. With the obstacle at a temperature θ_O the shift is the whole lifting
L = −θ_A r + θ_O s, s(x) = c x, the constant law's steady temperature: Θ = θ − L.

Every function below takes UFL arguments, coefficients and constants and returns a UFL form or
expression; nothing but ufl is imported, so the same functions feed dolfinx's
JIT at run time and ``ffcx`` ahead of time.

Measures are passed in, because the scheme's L2 products (·,·) and the point x = 1 are choices of
the discretisation, not of the equations:

* ``dx_m``: the measure of the mass terms (Θⁿ − Θⁿ⁻¹, w) and (Uⁿ − 2Uⁿ⁻¹ + Uⁿ⁻², v). Exact
  quadrature gives the consistent mass matrix M; vertex quadrature gives the paper's lumped M.
* ``dx``: every other integral over I (all are exact for P1 with any rule of degree ≥ 2).
* ``ds_1``: the boundary point x = 1, so that ``f * ds_1`` is f(1).
* ``dx_b``: the inertia's product b (u_tt, v), where it differs from ``dx_m``: a mass
  redistributed away from x = 1 (:func:`inertia`). None is ``dx_m``.
"""

import ufl


def positive_part(s):
    """[s]_+ = max(s, 0)."""
    return ufl.max_value(s, 0.0)


def robin_shift(x, k):
    """r(x) = c x − 1 with c = k/(k + 1): θ̂ = θ + θ_A r vanishes at x = 0 and satisfies
    the homogeneous Robin condition −θ̂_x(1) = k θ̂(1) (Remark 2.2)."""
    c = k / (k + 1.0)
    return c * x[0] - 1.0


def obstacle_shift(x, k):
    """s(x) = c x: the steady temperature of the constant law for θ_A = 0 and the obstacle at
    θ_O = 1, so that L = −θ_A r + θ_O s meets θ(0) = θ_A and −L_x(1) = k (L(1) − θ_O)."""
    c = k / (k + 1.0)
    return c * x[0]


def lifting(r, s, theta_A, theta_O):
    """L = −θ_A r + θ_O s: the temperature θ = Θ + L of the shifted one. θ_O = 0 gives the
    paper's θ = Θ − θ_A r."""
    return theta_O * s - theta_A * r


def inertia(f, v, dx_b):
    """(f, v) in the inertia's inner product: ``f * v * dx_b`` for a measure, or for a mass
    redistributed away from the contact node (Khenous, Laborde & Renard) a sum of weighted
    integrals, ``dx_b`` a sequence of (density ρ, measure) pairs: Σ ∫ ρ f v."""
    if isinstance(dx_b, ufl.Measure):
        return f * v * dx_b
    return sum(ρ * f * v * measure for ρ, measure in dx_b)


def heat(Θ, Θ_prev, U, U_prev, w, dt, a, k, dx_m, dx, ds_1):
    """Residual of (3.1), tested with w:

        (Θⁿ − Θⁿ⁻¹, w)/Δt + (Θⁿ_x, w_x) + a (Uⁿ_x − Uⁿ⁻¹_x, w)/Δt + k Θⁿ(1) w(1).

    With U the previous Picard iterate U^{n,l−1} this is (3.3)."""
    return (
        (Θ - Θ_prev) / dt * w * dx_m
        + Θ.dx(0) * w.dx(0) * dx
        + a / dt * (U.dx(0) - U_prev.dx(0)) * w * dx
        + k * Θ * w * ds_1
    )


def momentum(U, U_prev, U_prev2, Θ, v, dt, b, zeta, a, theta_A, r, dx_m, dx, dx_b=None,
             theta_O=None, s=None):
    """Residual of (3.2) without its contact term, tested with v:

        b (Uⁿ − 2Uⁿ⁻¹ + Uⁿ⁻², v)/Δt² + (Uⁿ_x − aΘⁿ + aθ_A r, v_x) + ζ (Uⁿ_x − Uⁿ⁻¹_x, v_x)/Δt

    and with an obstacle at θ_O (``theta_O`` and ``s`` given) − aθ_O (s, v_x): together
    (Uⁿ_x − aθⁿ, v_x) for the temperature θ = Θ + L (:func:`lifting`), the paper's terms kept
    as they are. With Θ = Θ^{n,l} and U = U^{n,l} this is (3.4) less its contact term."""
    return (
        inertia(b * (U - 2.0 * U_prev + U_prev2) / dt**2, v, dx_m if dx_b is None else dx_b)
        + (U.dx(0) - a * Θ + a * theta_A * r) * v.dx(0) * dx
        + zeta / dt * (U.dx(0) - U_prev.dx(0)) * v.dx(0) * dx
        + obstacle_temperature(a, theta_O, s, v, dx)
    )


def obstacle_temperature(a, theta_O, s, v, dx):
    """−aθ_O (s, v_x): the thermal stress of the lifting's θ_O part, an integral of its own
    (none without ``theta_O``)."""
    return 0 if theta_O is None else -a * theta_O * s * v.dx(0) * dx


# The same two equations written for the increments ΔΘⁿ = Θⁿ − Θⁿ⁻¹ and ΔUⁿ = Uⁿ − Uⁿ⁻¹, as the
# paper does with δⁿ − δⁿ⁻¹ in the proof of Theorem 4.3. No term is a difference of two functions
# of size |Θ| or |U|: solving for the increment computes it to its own accuracy, where solving
# (3.2) for Uⁿ loses |U| ε_mach/Δt² of the acceleration.
#
# One weight w places them in the step (rodfem.solver.time_schemes): w = 1 is (3.1)–(3.2) term by
# term; w = ½ is Crank–Nicolson (the implicit midpoint rule on the first-order system u_t = v,
# b v_t = σ_x, θ_t = θ_xx − a v_x). With D = Δt V the displacement the velocity makes over a step,
# the midpoint rule reads (Uⁿ − Uⁿ⁻¹)/Δt = (Vⁿ + Vⁿ⁻¹)/2, i.e. Dⁿ = 2ΔUⁿ − Dⁿ⁻¹, so that
# V^{n−½} = ΔUⁿ/Δt is the paper's δⁿ and b (Vⁿ − Vⁿ⁻¹)/Δt = 2b (ΔUⁿ − Dⁿ⁻¹)/Δt². Tested with
# Θ^{n−½} and δⁿ, the two equations give the energy identity of docs/time-schemes.md exactly.


def heat_increment(ΔΘ, Θ_prev, ΔU, w, dt, a, k, dx_m, dx, ds_1, weight=1.0):
    """(3.1) at tⁿ⁻¹ + weight·Δt, with Θ = Θⁿ⁻¹ + weight·ΔΘⁿ and Uⁿ − Uⁿ⁻¹ = ΔUⁿ:

        (ΔΘⁿ, w)/Δt + (Θ_x, w_x) + a (ΔUⁿ_x, w)/Δt + k Θ(1) w(1)."""
    Θ = Θ_prev + weight * ΔΘ
    return (
        ΔΘ / dt * w * dx_m
        + Θ.dx(0) * w.dx(0) * dx
        + a / dt * ΔU.dx(0) * w * dx
        + k * Θ * w * ds_1
    )


def momentum_increment(ΔU, D_prev, U_prev, Θ, v, dt, b, zeta, a, theta_A, r, dx_m, dx,
                       weight=1.0, dx_b=None, theta_O=None, s=None):
    """(3.2) at tⁿ⁻¹ + weight·Δt without its contact term, with U = Uⁿ⁻¹ + weight·ΔUⁿ, Θ the
    temperature there and Dⁿ⁻¹ the velocity's displacement over the last step (Uⁿ⁻¹ − Uⁿ⁻² in
    the paper's scheme):

        b (ΔUⁿ − Dⁿ⁻¹, v)/(weight Δt²) + (U_x − aΘ + aθ_A r, v_x) + ζ (ΔUⁿ_x, v_x)/Δt,

    and − aθ_O (s, v_x) for an obstacle at θ_O (as :func:`momentum`)."""
    U = U_prev + weight * ΔU
    return (
        inertia(b / weight * (ΔU - D_prev) / dt**2, v, dx_m if dx_b is None else dx_b)
        + (U.dx(0) - a * Θ + a * theta_A * r) * v.dx(0) * dx
        + zeta / dt * ΔU.dx(0) * v.dx(0) * dx
        + obstacle_temperature(a, theta_O, s, v, dx)
    )


def source(f, v, dx):
    """−(f, v): a body source f of the heat or the momentum equation, θ_t − θ_xx + a u_xt = f or
    b u_tt − σ_x = f. Only a scene that has one (a manufactured solution) pays for it."""
    return -f * v * dx


def contact_pressure(U, epsilon, gap, exponent=1.0):
    """(1/ε) [U(1) − g]_+^m = −σ(1): the elastic obstacle's reaction, (1.5) for m = 1 and normal
    compliance for m > 1 (rodfem.model.contact)."""
    return positive_part(U - gap) ** exponent / epsilon


def contact(p, v, ds_1):
    """The contact term p v(1) of (3.2), p = (1/ε)[Uⁿ(1) − g]_+. In (3.4) the pressure is taken at
    the previous iterate, p = (1/ε)[U^{n,l−1}(1) − g]_+, which makes it a load."""
    return p * v * ds_1


def energy(Θ, U, U_prev, dt, b, a, theta_A, r, epsilon, gap, dx_m, dx, ds_1, exponent=1.0,
           dx_b=None, theta_O=None, s=None):
    """Êⁿ of Remark 4.4, with δⁿ = (Uⁿ − Uⁿ⁻¹)/Δt and the norms of the scheme's inner product:

        ½ (‖Θⁿ‖² + b‖δⁿ‖² + ‖Uⁿ_x‖²) + [Uⁿ(1) − g]_+^{m+1}/((m + 1)ε) + a θ_A (r, Uⁿ_x),

    the contact term (1/2ε)[Uⁿ(1) − g]_+² of the paper for m = 1; and − aθ_O (s, Uⁿ_x) for an
    obstacle at θ_O: the last two are −a (L, Uⁿ_x) (docs/model.md)."""
    δ = (U - U_prev) / dt
    m1 = exponent + 1.0
    return 0.5 * (
        Θ**2 * dx_m
        + (b * δ**2 * dx_m if dx_b is None else inertia(b * δ, δ, dx_b))
        + U.dx(0) ** 2 * dx
    ) + positive_part(U - gap) ** m1 / (m1 * epsilon) * ds_1 + a * theta_A * r * U.dx(0) * dx \
        + (0 if theta_O is None else -a * theta_O * s * U.dx(0) * dx)


def temperature(Θ, L):
    """The physical temperature θ = Θ + L (Θ − θ_A r for the obstacle at θ_O = 0)."""
    return Θ + L


def stress(U, U_prev, θ, dt, zeta, a):
    """The Kelvin–Voigt stress σ = u_x + ζ u_xt − a θ, with u_xt ≈ (Uⁿ_x − Uⁿ⁻¹_x)/Δt."""
    return U.dx(0) + zeta * (U.dx(0) - U_prev.dx(0)) / dt - a * θ


def heat_flux(θ):
    """The heat flux q = −θ_x (Fourier's law; the model's conductivity is 1): at x = 1 it is
    h (θ(1) − θ_O), the heat given to the obstacle."""
    return -θ.dx(0)


def exchange(q, θ, theta_O, w, ds_1):
    """The heat the contact adds to the paper's k θ̂(1) w(1) at x = 1: q (θ(1) − θ_O) w(1), with
    h = k + q the exchange law's coefficient (rodfem.model.exchange). The paper's term k Θ(1)
    w(1) in (3.1) is the exchange k (θ(1) − θ_O) of the constant law, Θ's lifting L carrying
    the rest of it; q depends on the step (the contact pressure or the gap), so the methods
    take this term as a load on the one node x = 1: its value there is q (θ(1) − θ_O)."""
    return q * (θ - theta_O) * w * ds_1


# The matrices of Section 3 that the discrete energy needs: M_ij = (η_i, η_j), K_ij = (η_i', η_j')
# and z_i = (r, η_i').


def mass(u, v, dx_m):
    """(u, v) in the scheme's inner product: M."""
    return u * v * dx_m


def stiffness(u, v, dx):
    """(u_x, v_x): K."""
    return u.dx(0) * v.dx(0) * dx


def thermal_load(r, v, dx):
    """(r, v_x): z (and (L, v_x) for the lifting L)."""
    return r * v.dx(0) * dx


# The operators of the dynamic problem linearised about a steady state (rodfem.solver.spectrum):
# besides M, K and the inertia's (·,·)_b, the coupling and the point x = 1.


def coupling(u, w, dx):
    """(u_x, w): the heat equation's coupling a (u_xt, w), less a and the time derivative."""
    return u.dx(0) * w * dx


def end_product(u, v, ds_1):
    """u(1) v(1): B, the exchange and the contact at x = 1."""
    return u * v * ds_1
