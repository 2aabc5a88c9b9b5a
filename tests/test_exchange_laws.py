"""The heat-exchange laws at x = 1 (rodfem.model.exchange): their coefficients and slopes, the
scene's choice of one, and the lifting L = −θ_A r + θ_O s of the obstacle's temperature."""

import math

import numpy as np
import pytest

from rodfem.model import exchange
from rodfem.model.robin import lifting, robin_shift
from rodfem.scene import load, validate


def scene(**values):
    """paper1 with ``section__key=value`` overrides."""
    data = load("paper1").data()
    for name, value in values.items():
        section, key = name.split("__")
        data.setdefault(section, {})[key] = value
    return validate(data, "test")


def test_the_scene_picks_the_law_and_its_parameters():
    constant = exchange.of_scene(scene(model__k=3.0, obstacle__temperature=2.0))
    assert (constant.name, constant.variable, constant.k, constant.temperature) == (
        "constant", False, 3.0, 2.0)
    pressure = exchange.of_scene(scene(heat_exchange__law="pressure", heat_exchange__k1=5.0,
                                       heat_exchange__exponent=0.5))
    assert (pressure.name, pressure.k1, pressure.exponent) == ("pressure", 5.0, 0.5)
    gap = exchange.of_scene(scene(heat_exchange__law="gap", heat_exchange__k1=2.0,
                                  heat_exchange__length=0.05, obstacle__gap=0.2))
    assert (gap.name, gap.k1, gap.gap, gap.length) == ("gap", 2.0, 0.2, 0.05)


def test_pressure_law():
    law = exchange.PressureLaw(1.0, 0.0, k1=4.0, exponent=1.5)
    assert law.extra(0.3, 0.0) == 0.0  # separated: only k
    assert law.extra(0.3, 0.25) == 4.0 * 0.25**1.5
    assert law.coefficient(0.3, 0.25) == 1.0 + 4.0 * 0.25**1.5
    assert exchange.PressureLaw(1.0, 0.0, 4.0, 1.0).extra_slopes(0.0, 0.0) == (0.0, 4.0)
    assert exchange.PressureLaw(1.0, 0.0, 4.0, 2.0).extra_slopes(0.0, 0.0) == (0.0, 0.0)
    assert exchange.PressureLaw(1.0, 0.0, 4.0, 0.5).extra_slopes(0.0, 0.0) == (0.0, math.inf)


def test_gap_law_is_continuous_and_k1_in_contact():
    law = exchange.GapLaw(1.0, 0.0, k1=3.0, gap=0.1, length=0.02)
    assert law.extra(0.1, 0.0) == 3.0 and law.extra(0.5, 7.0) == 3.0
    assert abs(law.extra(0.08, 0.0) - 3.0 * math.exp(-1.0)) < 4e-16 * 3.0
    below = [law.extra(0.1 - d, 0.0) for d in (1e-6, 1e-9, 1e-12)]
    assert np.all(np.diff(below) > 0.0) and 3.0 - below[-1] < 1e-9


@pytest.mark.parametrize("law", [exchange.PressureLaw(0.5, 1.0, 4.0, 1.7),
                                 exchange.PressureLaw(0.5, 1.0, 4.0, 0.6),
                                 exchange.GapLaw(0.5, 1.0, 3.0, 0.1, 0.02)])
def test_slopes_are_the_derivatives(law):
    """Central differences of q agree with extra_slopes away from the kinks, to the
    differences' truncation O(d²) and round-off O(eps/d)."""
    rng = np.random.default_rng(3)
    for y, p in zip(rng.uniform(0.0, 0.2, 20), rng.uniform(0.01, 2.0, 20), strict=True):
        if abs(y - 0.1) < 1e-3:
            continue
        d = 1e-6
        dy = (law.extra(y + d, p) - law.extra(y - d, p)) / (2 * d)
        dp = (law.extra(y, p + d) - law.extra(y, p - d)) / (2 * d)
        slope_y, slope_p = law.extra_slopes(y, p)
        scale = 1.0 + abs(law.extra(y, p))
        assert abs(dy - slope_y) < 1e-6 * scale / law_length(law)
        assert abs(dp - slope_p) < 1e-6 * scale / min(p, 1.0) ** 2


def law_length(law) -> float:
    return getattr(law, "length", 1.0) ** 2


def test_flux_and_offset():
    law = exchange.PressureLaw(2.0, 3.0, k1=1.0)
    theta, y, p = np.array([5.0, 4.0]), np.array([0.0, 0.2]), np.array([0.0, 0.5])
    assert np.array_equal(law.flux(theta, y, p), np.array([2.0 * 2.0, 2.5 * 1.0]))
    assert law.offset(9.0) == (9.0 - 3.0) / 3.0
    constant = exchange.ConstantLaw(2.0)
    assert np.array_equal(constant.flux(theta, y, p), 2.0 * theta)  # the paper's k θ(1)


def test_lifting_is_the_constant_laws_steady_temperature():
    """L(0) = θ_A, −L_x(1) = k (L(1) − θ_O), and for θ_O = 0 the paper's −θ_A r bit for bit."""
    k, theta_A, theta_O = 2.5, 7.0, -3.0
    x = np.linspace(0.0, 1.0, 11)
    L = lifting(x, k, theta_A, theta_O)
    slope = (L[-1] - L[0])
    assert L[0] == theta_A
    assert abs(-slope - k * (L[-1] - theta_O)) < 1e-13 * abs(theta_A)
    assert np.array_equal(lifting(x, k, theta_A), -theta_A * robin_shift(x, k))


def test_keys_follow_their_law_in_a_resolved_scene():
    """A resolved scene writes the keys of its law and no other's."""
    resolved = scene(heat_exchange__law="gap").to_toml()
    section = resolved.split("[heat_exchange]")[1].split("\n\n")[0]
    assert "length = 0.01" in section and "k1 = 1.0" in section
    assert "exponent" not in section
    assert "k1" not in scene().to_toml().split("[heat_exchange]")[1].split("\n\n")[0]


@pytest.mark.parametrize("law", [exchange.PressureLaw(0.5, 1.0, 4.0, 1.7),
                                 exchange.PressureLaw(0.5, 1.0, 4.0, 0.6),
                                 exchange.GapLaw(0.5, 1.0, 3.0, 0.1, 0.02),
                                 exchange.ConstantLaw(0.5, 1.0)])
def test_vectorised_coefficients_are_the_scalar_ones(law):
    """The history's h (and heat_flux_1) in NumPy's terms: the scalar law's value at each pair,
    to the last bit or two of a power or an exponential."""
    rng = np.random.default_rng(5)
    y = np.concatenate([rng.uniform(-0.2, 0.3, 50), [0.1, 0.1 - 1e-12]])
    p = np.concatenate([rng.uniform(0.0, 2.0, 50) * (rng.random(50) < 0.7), [0.0, 1e-300]])
    h = law.coefficients(y, p)
    scalar = np.array([law.coefficient(a, b) for a, b in zip(y, p, strict=True)])
    assert np.all(np.abs(h - scalar) <= 4 * np.finfo(float).eps * np.abs(scalar))
