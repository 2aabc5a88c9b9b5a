"""A UFL file for ahead-of-time compilation: ``ffcx copetti_p1.py``.

It builds the scheme (3.1)–(3.4) from ``forms.copetti`` on an abstract P1 interval, with every
parameter a UFL constant, exactly as the run-time JIT gets it.
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
Θ, Θ_prev, Θ_iterate = ufl.Coefficient(V), ufl.Coefficient(V), ufl.Coefficient(V)
U, U_prev, U_prev2, U_iterate = (ufl.Coefficient(V) for _ in range(4))
dt, a, b, zeta, k, theta_A, epsilon, gap = (ufl.Constant(domain) for _ in range(8))
w, du = ufl.TestFunction(V), ufl.TrialFunction(V)
dx_m = ufl.dx(scheme="GLL", degree=1)  # lumped mass
ds_1 = ufl.ds(1)
r = copetti.robin_shift(ufl.SpatialCoordinate(domain), k)

heat = copetti.heat(Θ, Θ_prev, U_iterate, U_prev, w, dt, a, k, dx_m, ufl.dx, ds_1)  # (3.3)
momentum = copetti.momentum(U, U_prev, U_prev2, Θ_iterate, w, dt, b, zeta, a, theta_A, r, dx_m,
                            ufl.dx) + copetti.contact(copetti.contact_pressure(U_iterate, epsilon,
                                                                               gap), w, ds_1)
energy = copetti.energy(Θ, U, U_prev, dt, b, a, theta_A, r, epsilon, gap, dx_m, ufl.dx, ds_1)

heat_matrix = ufl.derivative(heat, Θ, du)
momentum_matrix = ufl.derivative(momentum, U, du)
forms = [heat, heat_matrix, momentum, momentum_matrix, energy]
