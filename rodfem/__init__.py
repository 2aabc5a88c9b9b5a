"""rodfem: dynamic contact of a thermoviscoelastic rod with an obstacle, in FEniCSx.

Copetti's scheme: a heat equation coupled to a Kelvin–Voigt wave equation on (0, 1), penalty
contact with an elastic obstacle at x = 1, P1 elements and a Picard loop per time step.
"""

__version__ = "0.1.0"
