"""Property-based fuzzing of scene loading: whatever a scene file or a --set holds, loading it
gives a valid scene or one SceneError of one line, and never runs what it was given.

A few hundred examples here; ``make fuzz`` runs 10⁴ of each (HYPOTHESIS_PROFILE=fuzz).
"""

import math
import os

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from conftest import COMM
from rodfem.scene import SCHEMA, SceneError, load

serial_only = pytest.mark.skipif(COMM.size > 1, reason="no MPI in scene loading: serially only")
settings.register_profile("suite", max_examples=150, deadline=None,
                          suppress_health_check=[HealthCheck.too_slow])
settings.register_profile("fuzz", max_examples=10_000, deadline=None,
                          suppress_health_check=[HealthCheck.too_slow])
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "suite"))

SECTIONS = list(SCHEMA)
KEYS = sorted({key for section in SCHEMA.values() for key in section})
EXPRESSIONS = ["x", "sin(pi*x)", "x*1e300", "__import__('os')", "().__class__", "x**x**x",
               "exp(1000*x)", "1/x", "theta_A*(cos(2*pi*x) - sin(pi*x/2))", "t", "lambda: 0",
               "open('/etc/passwd')", "x if x else 0", "[x]", "{}", "x.real", "a*b", "'s'"]
CHOICES = ["picard", "direct", "newton", "rigid", "elastic", "linear", "power", "lumped",
           "consistent", "paper", "crank-nicolson", "PICARD", ""]

class Huge:
    """An integer of 4,301 digits, more than Python converts from text by default."""

    def __repr__(self):
        return "Huge()"


HUGE = Huge()
scalars = st.one_of(
    st.integers(min_value=-10**6, max_value=10**6),
    st.sampled_from([0, 1, 2, -1, 2**63, 10_000_001, 100_000_001]),
    st.just(HUGE),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([1e-300, 5e-324, 1e308, -0.0, 1e12, 1e13]),
    st.booleans(),
    st.sampled_from(EXPRESSIONS + CHOICES),
    st.text(max_size=30),
)
def _lists(inner):
    return st.lists(inner, max_size=3)


values = st.recursive(scalars, _lists, max_leaves=6)
names = st.one_of(st.sampled_from(KEYS), st.text(min_size=1, max_size=12))


def toml_value(value) -> str:
    if value is HUGE:
        return "9" * 4301
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    return '"' + value.encode("unicode_escape").decode("ascii").replace('"', '\\"') + '"'


def toml_key(name: str) -> str:
    return name if name.replace("_", "").isalnum() and name.isascii() else toml_value(name)


@st.composite
def documents(draw) -> str:
    lines = []
    if draw(st.booleans()):
        lines.append(f"description = {toml_value(draw(scalars))}")
    for section in draw(st.lists(st.one_of(st.sampled_from(SECTIONS), names), max_size=5,
                                 unique=True)):
        lines.append(f"[{toml_key(section)}]")
        for key in draw(st.lists(names, max_size=4, unique=True)):
            lines.append(f"{toml_key(key)} = {toml_value(draw(values))}")
    return "\n".join(lines) + "\n"


def loads_or_one_line(path: str, overrides=()) -> None:
    try:
        load(path, list(overrides))
    except SceneError as err:
        message = str(err)
        assert message and "\n" not in message and len(message) < 2000, message


@serial_only
@given(documents())
def test_any_scene_file_loads_or_is_one_line(tmp_path_factory, text):
    path = tmp_path_factory.mktemp("scene") / "s.toml"
    path.write_text(text, encoding="utf-8")
    loads_or_one_line(str(path))


@serial_only
@given(st.binary(max_size=200))
def test_any_bytes_load_or_are_one_line(tmp_path_factory, data):
    path = tmp_path_factory.mktemp("scene") / "s.toml"
    path.write_bytes(data)
    loads_or_one_line(str(path))


@serial_only
@given(st.lists(st.one_of(
    st.builds("{}.{}={}".format, st.sampled_from(SECTIONS), names,
              st.one_of(values.map(toml_value), st.text(max_size=20))),
    st.text(max_size=40)), max_size=3))
def test_any_overrides_load_or_are_one_line(overrides):
    loads_or_one_line("paper1", overrides)


@pytest.mark.parametrize("override", [
    'time.adaptive=["\\u001f", ' + "9" * 4000 + "]",  # found by the fuzzing above
    "time.scheme=" + "9" * 4000,
    "output.fields=[" + ", ".join(['"u"'] * 2) + ", " + "9" * 4000 + "]",
    "model.zeta" + "x" * 4000,
    "time. " + "x" * 4000 + "=1",
    "model." + "x" * 4000 + "=1",
    "x" * 4000 + ".zeta=1",
], ids=["boolean", "choice", "list", "no value", "space", "key", "section"])
def test_a_long_value_is_quoted_short(override):
    with pytest.raises(SceneError) as err:
        load("paper1", [override])
    assert "\n" not in str(err.value) and len(str(err.value)) < 300, str(err.value)


LONG = "x" * 4000


@serial_only
@pytest.mark.parametrize("text", [
    f'[measures]\np = {{ column = "{LONG}", reduce = "max" }}\n',
    f'[measures]\np = {{ column = "u_1", reduce = "max", target = "{LONG}" }}\n',
    f'[measures]\np = {{ column = "u_1", reduce = "{LONG}" }}\n',
    f'[measures]\np = {{ column = "u_1", reduce = "max", {LONG} = 1 }}\n',
    f'[measures]\n{LONG} = {{ column = "nothing", reduce = "max" }}\n',
    f'[measures]\nA{LONG} = {{ column = "u_1", reduce = "max" }}\n',
    f'[{LONG}]\n',
    f'[model]\n{LONG} = 1\n',
    f'[measures]\n{LONG} = {{ column = "t", reduce = "max", target = 0.01 }}\n',
], ids=["column", "target", "reduce", "key", "name", "bad name", "section", "model key",
        "stepped target"])
def test_a_long_name_in_a_scene_file_is_quoted_short(tmp_path_factory, text):
    path = tmp_path_factory.mktemp("scene") / "s.toml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(SceneError) as err:
        load(str(path))
    assert "\n" not in str(err.value) and len(str(err.value)) < 400, str(err.value)
