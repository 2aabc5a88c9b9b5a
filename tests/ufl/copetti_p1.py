"""A UFL file for ahead-of-time compilation: ``ffcx copetti_p1.py``.

It builds, from ``forms.copetti``, the forms the solver compiles at run time — the residuals of
(3.3) and (3.4) in increments with the matrices read off them, the contact load, and the matrices
of the energy — with every parameter a UFL constant, for both mass matrices; and the paper's
(3.1)–(3.2) as printed, with the energy of Remark 4.4.
"""

import ufl

import forms.copetti as copetti

try:  # UFL 2023+ (dolfinx ≥ 0.7) takes elements from basix
    import basix.ufl

    element = basix.ufl.element("Lagrange", "interval", 1)
    domain = ufl.Mesh(basix.ufl.element("Lagrange", "interval", 1, shape=(1,)))
except (ImportError, AttributeError):  # UFL 2022 (dolfinx 0.5)
    element = ufl.FiniteElement("Lagrange", ufl.interval, 1)
    domain = ufl.Mesh(ufl.VectorElement("Lagrange", ufl.interval, 1))

V = ufl.FunctionSpace(domain, element)
Θ, Θ_prev, ΔΘ = (ufl.Coefficient(V) for _ in range(3))
U, U_prev, U_prev2, ΔU, ΔU_prev, ΔU_iterate = (ufl.Coefficient(V) for _ in range(6))
dt, a, b, zeta, k, theta_A, epsilon, gap = (ufl.Constant(domain) for _ in range(8))
w, du = ufl.TestFunction(V), ufl.TrialFunction(V)
ds_1 = ufl.ds(1)
r = copetti.robin_shift(ufl.SpatialCoordinate(domain), k)

forms = []
for dx_m in (ufl.dx(scheme="GLL", degree=1), ufl.dx):  # lumped, consistent mass
    heat = copetti.heat_increment(ΔΘ, Θ_prev, ΔU_iterate, w, dt, a, k, dx_m, ufl.dx, ds_1)
    momentum = copetti.momentum_increment(ΔU, ΔU_prev, U_prev, Θ, w, dt, b, zeta, a, theta_A, r,
                                          dx_m, ufl.dx)
    forms += [heat, momentum]
    forms += [ufl.derivative(heat, f, du) for f in (ΔΘ, Θ_prev, ΔU_iterate)]
    forms += [ufl.derivative(momentum, f, du) for f in (ΔU, ΔU_prev, U_prev, Θ)]
    forms += [copetti.mass(du, w, dx_m), copetti.stiffness(du, w, ufl.dx)]
    paper = copetti.heat(Θ, Θ_prev, U, U_prev, w, dt, a, k, dx_m, ufl.dx, ds_1)
    paper += copetti.momentum(U, U_prev, U_prev2, Θ, w, dt, b, zeta, a, theta_A, r, dx_m, ufl.dx)
    paper += copetti.contact(copetti.contact_pressure(U, epsilon, gap), w, ds_1)
    forms += [paper, copetti.energy(Θ, U, U_prev, dt, b, a, theta_A, r, epsilon, gap, dx_m,
                                    ufl.dx, ds_1)]
forms += [copetti.contact(1.0, w, ds_1), copetti.thermal_load(r, w, ufl.dx)]
