"""The whitelisted expression parser: what it accepts, what it refuses, and that it never runs
user text as Python."""

import numpy as np
import pytest

from rodfem.scene.expressions import Expression, ExpressionError

NAMES = ("a", "b", "zeta", "k", "theta_A")
PARAMS = {"a": 0.017, "b": 1.0, "zeta": 0.2, "k": 1.0, "theta_A": 10.0}


@pytest.mark.parametrize(
    "text, expected",
    [
        (
            "theta_A*(cos(2*pi*x) - sin(pi*x/2))",
            lambda x: 10 * (np.cos(2 * np.pi * x) - np.sin(np.pi * x / 2)),
        ),
        ("20*x*(x - 1)**2", lambda x: 20 * x * (x - 1) ** 2),
        ("0", lambda x: 0 * x),
        ("-x + +1", lambda x: 1 - x),
        (
            "exp(-x)*log(1 + x) + sqrt(x) - abs(x - 0.5) + tan(x/4)",
            lambda x: np.exp(-x) * np.log(1 + x) + np.sqrt(x) - np.abs(x - 0.5) + np.tan(x / 4),
        ),
        ("a*theta_A*(x - k/(k + 1)*x**2/2)", lambda x: 0.17 * (x - 0.25 * x**2)),
    ],
)
def test_evaluates_like_numpy(text, expected):
    x = np.linspace(0, 1, 11)
    values = Expression(text, NAMES)(x, PARAMS)
    np.testing.assert_allclose(values, expected(x), rtol=1e-15, atol=1e-15)


@pytest.mark.parametrize(
    "text, fragment",
    [
        ("__import__('os').system('true')", "calls"),
        ("x.__class__", "contains"),
        ("open('f')", "calls 'open'"),
        ("y + 1", "unknown name 'y'"),
        ("thetaA*x", "did you mean 'theta_A'"),
        ("sinn(x)", "did you mean 'sin'"),
        ("'a'", "only numbers"),
        ("x if x else 1", "contains"),
        ("[x]", "contains"),
        ("lambda: 1", "contains"),
        ("x +", "not a valid expression"),
        ("x % 2", "operator"),
        ("x // 2", "operator"),
        ("sin(x, x)", "one argument"),
        ("(" * 300 + "x" + ")" * 300, "not a valid expression"),
        ("x" + " + x" * 400, "longer than 1000"),
        ("True", "only numbers"),
        ("1j", "only numbers"),
    ],
)
def test_refuses(text, fragment):
    with pytest.raises(ExpressionError, match=None) as info:
        Expression(text, NAMES)
    assert fragment in str(info.value)


def test_huge_powers_stay_floats():
    """10**10**10 would hang with Python integers; as floats it overflows to inf at once."""
    assert np.isinf(Expression("10**10**10", NAMES)(np.zeros(2), PARAMS)).all()


def test_transcendental_functions_and_powers_are_the_c_librarys_bit_for_bit():
    """The same bits on every machine: NumPy's own sin, exp, power… are SVML's on a processor
    with AVX-512, rounded otherwise than the C library's (rodfem.scene.expressions._libm)."""
    import math

    rng = np.random.default_rng(7)
    x = rng.uniform(-3.0, 3.0, 1001)
    for name, function in (("sin", math.sin), ("cos", math.cos), ("tan", math.tan),
                           ("exp", math.exp)):
        got = Expression(f"{name}(x)", ())(x, {})
        assert got.tobytes() == np.array([function(v) for v in x]).tobytes(), name
    got = Expression("log(x)", ())(np.abs(x) + 0.1, {})
    assert got.tobytes() == np.array([math.log(v) for v in np.abs(x) + 0.1]).tobytes()
    got = Expression("(x - 1)**2 + abs(x)**k", ("k",))(x, {"k": 2.5})
    want = [math.pow(v - 1.0, 2.0) + math.pow(abs(v), 2.5) for v in x]
    assert got.tobytes() == np.array(want).tobytes()
    # where the C library raises, NumPy's value: nan, ±inf, as before
    points = np.array([-1.0, 0.0, 2.0])
    logs, exps = Expression("log(x)", ())(points, {}), Expression("exp(1000*x)", ())(points, {})
    roots = Expression("(-x)**0.5", ())(points, {})
    assert np.isnan(logs[0]) and logs[1] == -np.inf and exps[2] == np.inf
    assert roots[0] == 1.0 and roots[1] == 0.0 and np.isnan(roots[2])


def test_kept_parts_give_a_fresh_evaluations_bits():
    """A source evaluated step after step keeps its parts in x alone; whatever changes between
    calls (t, another parameter, the points, in place or not), each value is a fresh
    expression's bit for bit, and a part in x and t is never kept across a change of t."""
    text = "exp(-t)*x*(1 - x)**2 + a*cos(pi*x/2)*sin(t) + sin(x*t)**2"
    kept = Expression(text, {"a", "t"})
    x = np.linspace(0.0, 1.0, 17)
    calls = [(x, {"a": 0.5, "t": 0.1}), (x, {"a": 0.5, "t": 0.2}), (x, {"a": 0.7, "t": 0.2}),
             (x[:9], {"a": 0.7, "t": 0.2}), (x, {"a": 0.7, "t": 0.3})]
    for points, parameters in calls:
        fresh = Expression(text, {"a", "t"})(points, parameters)
        assert kept(points, parameters).tobytes() == fresh.tobytes()
    x *= 2.0  # the caller's points changed in place
    assert kept(x, {"a": 0.7, "t": 0.3}).tobytes() == \
        Expression(text, {"a", "t"})(x, {"a": 0.7, "t": 0.3}).tobytes()
