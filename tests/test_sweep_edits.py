"""Any edit of a sweep directory's files (sweep.json, a journal part, results.csv, summary.json,
rodfem.json: cut, a byte changed, a value of the wrong type, removed, or a directory in its
place), then ``rodfem resume``: either the table an uninterrupted sweep writes (but its
timings), or exit code 2 with one line and nothing changed. Serially and under mpirun (the
examples are drawn alike on every rank)."""

import json
import shutil
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_sweep_safety import GRID, killed, same_rows, snapshot, write

from conftest import COMM
from rodfem.cli import main
from rodfem.output import journal
from rodfem.output import results as table

TARGETS = [("stopped", "sweep.json"), ("stopped", "rodfem.json"),
           ("stopped", "journal/part-0000-00000.bin"), ("stopped", "journal"),
           ("complete", "sweep.json"), ("complete", "results.csv"),
           ("complete", "summary.json"), ("complete", "rodfem.json")]
VALUES = [None, "x", 5, -1, 2.5, True, [], {}, "complete", "sweep"]
EDITS = st.one_of(
    st.tuples(st.just("cut"), st.floats(0, 1)),
    st.tuples(st.just("byte"), st.floats(0, 1), st.integers(1, 255)),
    st.tuples(st.just("remove")),
    st.tuples(st.just("replace"), st.sampled_from(["", "[]", '"x"', "5", "null", "{}", "a,b\n"])),
    st.tuples(st.just("value"), st.integers(0, 40), st.sampled_from(VALUES)),
    st.tuples(st.just("delete key"), st.integers(0, 40)),
    st.tuples(st.just("directory")),
)


@pytest.fixture(scope="module")
def templates():
    """A complete sweep, and one killed after two scenes per rank (with its journal)."""
    root = Path(tempfile.mkdtemp(prefix="rodfem-edits-")) if COMM.rank == 0 else None
    root = COMM.bcast(root, root=0)
    sweep = write(root / "grid.toml", GRID)
    assert main(["sweep", str(sweep), "--out", str(root / "complete"), "--quiet"]) == 0
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(journal, "remove", lambda out: None)
        assert main(["sweep", str(sweep), "--out", str(root / "stopped"), "--quiet"]) == 0
    killed(root / "stopped", 2)
    yield root
    COMM.barrier()
    if COMM.rank == 0:
        shutil.rmtree(root, ignore_errors=True)


def edit(path: Path, how: tuple) -> None:
    """Apply one edit to ``path`` (a file, or the journal directory)."""
    kind = how[0]
    if kind == "directory" or (path.is_dir() and kind != "remove"):
        shutil.rmtree(path) if path.is_dir() else path.unlink()
        path.mkdir() if kind == "directory" else path.write_text("not a directory")
        return
    if kind == "remove":
        shutil.rmtree(path) if path.is_dir() else path.unlink()
        return
    data = path.read_bytes()
    if kind == "cut":
        path.write_bytes(data[:int(how[1] * len(data))])
    elif kind == "byte" and data:
        at = min(int(how[1] * len(data)), len(data) - 1)
        path.write_bytes(data[:at] + bytes([data[at] ^ how[2]]) + data[at + 1:])
    elif kind == "replace":
        path.write_text(how[1])
    elif kind in ("value", "delete key"):
        try:
            content = json.loads(data)
        except ValueError:
            return
        if isinstance(content, dict) and content:
            key = sorted(content)[how[1] % len(content)]
            if kind == "value":
                content[key] = how[2]
            else:
                del content[key]
            path.write_text(json.dumps(content, indent=2))


@settings(max_examples=40, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(target=st.sampled_from(TARGETS), how=EDITS)
def test_an_edited_directory_resumes_to_the_same_table_or_is_refused(templates, target, how,
                                                                     capsys):
    which, name = target
    out = templates / "example"
    COMM.barrier()  # every rank is done reading the example before
    if COMM.rank == 0:
        shutil.rmtree(out, ignore_errors=True)
        shutil.copytree(templates / which, out)
        edit(out / name, how)
    before = snapshot(out)
    capsys.readouterr()
    code = main(["resume", str(out), "--quiet"])
    err = capsys.readouterr().err
    if code == 0:
        same_rows(out / table.NAME, templates / "complete" / table.NAME)
        assert json.loads((out / "rodfem.json").read_text())["status"] == "complete"
    else:
        assert code == 2, err
        if COMM.rank == 0:
            assert err.count("\n") == 1 and err.startswith("rodfem: error: "), err
        assert snapshot(out) == before
