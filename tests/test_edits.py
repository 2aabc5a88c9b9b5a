"""Every file of a stopped run's directory that a user, a script or a crash could have changed
(edited, cut, of the wrong type or shape, from another version) is either used or refused: after
any edit, ``rodfem resume`` continues to the result of an uninterrupted run bit for bit, or exits
with code 2 and one line, every file as it was.

The explicit cases first (edited checkpoints), then a property test over edits drawn by
hypothesis: a few examples in the suite, ``HYPOTHESIS_PROFILE=fuzz`` runs many more. A new file of
a run directory joins the property test as one entry of :data:`EDITS`.
"""

import contextlib
import hashlib
import io
import json
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from conftest import serial_only
from rodfem.cli import main

SCENE = ["paper1", "--set", "mesh.cells=20", "--set", "output.every=7"]
EXAMPLES = {"fuzz": 2000}.get(os.environ.get("HYPOTHESIS_PROFILE", "suite"), 100)


def rodfem(*args) -> subprocess.CompletedProcess:
    """The command, in this process (no start-up to wait for): its exit code and output."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([str(a) for a in args])
    return subprocess.CompletedProcess(args, code, out.getvalue(), err.getvalue())


def snapshot(out: Path) -> dict[str, str]:
    """Every file under ``out`` (its path inside) and the SHA-256 of its bytes."""
    return {str(p.relative_to(out)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(out.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """The uninterrupted run to t = 0.2, and two stopped at t = 0.1, each with how it
    continues: a finished run extended (resume --set time.end=0.2) and a run killed as it was
    being extended (its scene.toml says 0.2, its marker a dead process's)."""
    root = tmp_path_factory.mktemp("edits")
    assert rodfem("run", *SCENE, "--set", "time.end=0.2", "--out", root / "reference",
                  "--quiet").returncode == 0
    finished = root / "finished"
    assert rodfem("run", *SCENE, "--set", "time.end=0.1", "--out", finished,
                  "--quiet").returncode == 0
    killed = root / "killed"
    shutil.copytree(finished, killed)
    scene = killed / "scene.toml"
    scene.write_text(scene.read_text().replace("end = 0.1", "end = 0.2"))
    marker = json.loads((killed / "rodfem.json").read_text())
    marker.update(status="running", pid=2**22 + 1, resumed=marker["finished"])
    del marker["finished"]
    (killed / "rodfem.json").write_text(json.dumps(marker, indent=2))
    return {"reference": root / "reference",
            "finished": (finished, ["--set", "time.end=0.2"]), "killed": (killed, [])}


def assert_same_run(out: Path, reference: Path) -> None:
    from rodfem.output.readers import read_fields, read_history

    a, b = read_history(out / "history.h5"), read_history(reference / "history.h5")
    assert a.names == b.names and a.rows.tobytes() == b.rows.tobytes()
    a, b = read_fields(out / "fields.xdmf"), read_fields(reference / "fields.xdmf")
    for name in ("t", "x", *b.names):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    summary = json.loads((out / "summary.json").read_text())
    expected = json.loads((reference / "summary.json").read_text())
    for key in ("status", "steps", "iterations_total", "iterations_max", "energy_max_increase"):
        assert summary[key] == expected[key], key


def used_or_refused(out: Path, extra: list[str], reference: Path, before: dict) -> str:
    """Resume ``out``: the uninterrupted run's result, or one line, exit 2, nothing changed."""
    done = rodfem("resume", out, "--quiet", *extra)
    if done.returncode == 0:
        assert_same_run(out, reference)
        return "used"
    assert done.returncode == 2, done.stderr
    assert done.stderr.startswith("rodfem: error: ") and done.stderr.count("\n") == 1, \
        done.stderr
    assert snapshot(out) == before
    return done.stderr


# --- checkpoint.npz -------------------------------------------------------------------------

def read_npz(path: Path) -> tuple[dict, dict]:
    with np.load(path) as data:
        arrays = {name: data[name] for name in data.files}
    return arrays, json.loads(str(arrays["meta"]))


def write_npz(path: Path, arrays: dict, meta: dict | None = None) -> None:
    if meta is not None:
        arrays = {**arrays, "meta": np.array(json.dumps(meta))}
    with open(path, "wb") as file:
        np.savez(file, **arrays)


def set_meta(**values):
    """An edit of the checkpoint's metadata (None removes a field)."""
    def edit(arrays, meta):
        for key, value in values.items():
            meta.pop(key) if value is None else meta.__setitem__(key, value)
        return arrays, meta
    return edit


def set_array(name, value):
    def edit(arrays, meta):
        arrays = dict(arrays)
        arrays.pop(name) if value is None else arrays.__setitem__(name, value(arrays[name]))
        return arrays, meta
    return edit


CHECKPOINT_EDITS = {
    "state cut": set_array("state", lambda a: a[:-1]),
    "state reshaped": set_array("state", lambda a: a.reshape(3, -1)),
    "state missing": set_array("state", None),
    "u_prev missing": set_array("u_prev", None),
    "u_prev reshaped": set_array("u_prev", lambda a: a[:, None]),
    "step an array": set_array("step", lambda a: np.arange(5)),
    "pressure empty": set_array("pressure", lambda a: a[:0]),
    "state scaled by 1 + 1e-12": set_array("state", lambda a: a * (1 + 1e-12)),
    "state as float32": set_array("state", lambda a: a.astype(np.float32)),
    "meta step a string": set_meta(step="10"),
    "meta saves a string": set_meta(saves="x"),
    "meta scene a string": set_meta(scene="x"),
    "meta energy wrong": set_meta(energy={"last": "x"}),
    "meta iterations wrong": set_meta(iterations=[1, 2]),
    "meta step earlier": set_meta(step=50),
}


@serial_only
@pytest.mark.parametrize("edit", list(CHECKPOINT_EDITS))
@pytest.mark.parametrize("undigested", [False, True], ids=["", "without digest"])
def test_an_edited_checkpoint_is_refused_in_one_line(runs, tmp_path, edit, undigested):
    """Each edit, to the checkpoint as written, and to one whose digest was removed as well
    (as an earlier rodfem's, which this one does not resume)."""
    out = tmp_path / "run"
    shutil.copytree(runs["finished"][0], out)
    arrays, meta = read_npz(out / "checkpoint.npz")
    if undigested:
        meta = {**meta, "format": 1}
        del meta["digest"]
    write_npz(out / "checkpoint.npz", *CHECKPOINT_EDITS[edit](arrays, meta))
    before = snapshot(out)
    line = used_or_refused(out, ["--set", "time.end=0.2"], runs["reference"], before)
    assert line != "used" and str(out / "checkpoint.npz") in line


@st.composite
def checkpoint_edit(draw, path: Path) -> None:
    """Entries removed, reshaped, of another type, scaled; metadata fields removed or of
    another type; or the file cut."""
    if draw(st.integers(0, 5)) == 0:
        data = path.read_bytes()
        path.write_bytes(data[:draw(st.integers(0, len(data) - 1))])
        return
    arrays, meta = read_npz(path)
    if draw(st.booleans()):
        key = draw(st.sampled_from(sorted(meta)))
        value = draw(st.one_of(st.none(), st.integers(-3, 10**6), st.text(max_size=5),
                               st.floats(), st.lists(st.integers(0, 3), max_size=4)))
        write_npz(path, *set_meta(**{key: value})(arrays, meta))
        return
    name = draw(st.sampled_from(sorted(arrays)))
    change = draw(st.sampled_from(["remove", "reshape", "dtype", "scale", "cut"]))
    if name == "meta":  # its fields are edited above
        change = "remove"
    a = arrays[name]
    if change == "remove":
        del arrays[name]
    elif change == "reshape":
        arrays[name] = a.reshape(-1, 1) if a.ndim else a.reshape(1)
    elif change == "dtype":
        kind = draw(st.sampled_from([np.float32, np.int32, np.float64, np.int64, np.complex128]))
        arrays[name] = a.astype(kind) if a.dtype != kind else a.astype(np.float16)
    elif change == "scale" and a.dtype.kind == "f":
        arrays[name] = a * (1 + draw(st.sampled_from([1e-15, 1e-12, 1e-3, -1.0])))
    else:
        arrays[name] = a[: max(0, a.size - draw(st.integers(1, 3)))] if a.ndim else a.reshape(0)
    write_npz(path, arrays)


# --- rodfem.json ----------------------------------------------------------------------------

@st.composite
def marker_edit(draw, path: Path) -> None:
    """Fields removed or of another type, the file cut, or not JSON."""
    text = path.read_text()
    kind = draw(st.integers(0, 3))
    if kind == 0:
        path.write_text(text[:draw(st.integers(0, len(text) - 1))])
    elif kind == 1:
        path.write_bytes(draw(st.binary(max_size=40)))
    else:
        marker = json.loads(text)
        key = draw(st.sampled_from(sorted(marker)))
        if kind == 2:
            del marker[key]
        else:
            marker[key] = draw(st.one_of(st.none(), st.integers(-1, 2**31), st.booleans(),
                                         st.text(max_size=8), st.lists(st.integers(), max_size=2),
                                         st.sampled_from(["complete", "running", "run", "sweep"])))
        path.write_text(json.dumps(marker))


# --- scene.toml -----------------------------------------------------------------------------

@st.composite
def scene_edit(draw, path: Path) -> None:
    """A value changed or a line removed (not time.end's, the one a resumed run may change),
    junk added, or the file cut."""
    lines = path.read_text().splitlines(keepends=True)
    values = [i for i, line in enumerate(lines) if " = " in line and not line.startswith("end")]
    kind = draw(st.integers(0, 3))
    if kind == 0:
        i = draw(st.sampled_from(values))
        key = lines[i].split(" = ")[0]
        value = draw(st.one_of(st.integers(-5, 100), st.floats(allow_nan=False, width=32),
                               st.sampled_from(['"x"', '"picard"', "true", "[]", '"0"', "1e-3"])))
        lines[i] = f"{key} = {value}\n"
    elif kind == 1:
        lines.insert(draw(st.integers(0, len(lines))), draw(st.text(max_size=20)) + "\n")
    elif kind == 2:  # not time.end's line: without it the run continues to the default end
        del lines[draw(st.sampled_from([i for i, line in enumerate(lines)
                                        if not line.startswith("end")]))]
    text = "".join(lines)
    if kind == 3:
        text = text[:draw(st.integers(0, len(text) - 1))]
    path.write_text(text)


# --- history.h5 and the fields' HDF5 files -------------------------------------------------

@st.composite
def bytes_edit(draw, path: Path) -> None:
    """The file cut, a few of its bytes changed, or all of it replaced by junk."""
    data = bytearray(path.read_bytes())
    kind = draw(st.integers(0, 2))
    if kind == 0:
        del data[draw(st.integers(0, len(data) - 1)):]
    elif kind == 1:
        at = draw(st.integers(0, len(data) - 1))
        data[at:at + 4] = draw(st.binary(min_size=1, max_size=4))
    else:
        data = draw(st.binary(max_size=64))
    path.write_bytes(bytes(data))


# The files of a run directory and how they may be edited: a file rodfem adds is a line here.
EDITS = {"checkpoint.npz": checkpoint_edit, "rodfem.json": marker_edit, "scene.toml": scene_edit,
         "history.h5": bytes_edit, "fields/mesh.h5": bytes_edit,
         "fields/steps-000000.h5": bytes_edit}


@serial_only
@settings(max_examples=EXAMPLES, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(data=st.data(), name=st.sampled_from(sorted(EDITS)),
       stopped=st.sampled_from(["finished", "killed"]))
def test_any_edit_is_used_or_refused(runs, data, name, stopped):
    source, extra = runs[stopped]
    with tempfile.TemporaryDirectory() as root:
        out = Path(root) / "run"
        shutil.copytree(source, out)
        data.draw(EDITS[name](out / name), label=f"edit of {name}")
        before = snapshot(out)
        outcome = used_or_refused(out, extra, runs["reference"], before)
        event("used" if outcome == "used" else "refused")


def test_a_checkpoint_holds_its_digest():
    """The digest changes with any array's bytes, type or shape, and with the metadata."""
    from rodfem.output.checkpoint import digest

    arrays = {"state": np.arange(6.0), "step": np.array([3, 1])}
    meta = {"step": 3, "saves": [[0, 0.0, 0, 0]]}
    same = digest(arrays, meta)
    assert digest({**arrays}, {**meta, "digest": "x"}) == same
    for changed in ({**arrays, "state": np.arange(6.0) * (1 + 1e-15)},
                    {**arrays, "state": np.arange(6.0).astype(np.float32)},
                    {**arrays, "state": np.arange(6.0).reshape(2, 3)},
                    {"state": np.arange(6.0)}):
        assert digest(changed, meta) != same
    assert digest(arrays, {**meta, "step": 4}) != same
