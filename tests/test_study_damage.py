"""A study directory altered after it stopped (an entry replaced, removed or planted, its marker
edited) is refused by ``rodfem resume`` before anything is done: one line naming the entry and
what to do, exit code 2, every file as it was. Serially and under mpirun."""

import json
import os
import shutil
from pathlib import Path

import pytest

from conftest import COMM
from rodfem.cli import main
from test_study_signals import DATA, SMALL_FIT

SENSITIVITY = ('scene = "paper1"\nsamples = 4\noutputs = ["u_1_final"]\n[set]\n"mesh.cells" = 8\n'
               '"time.end" = 0.2\n"solver.method" = "direct"\n[parameters]\n'
               '"model.zeta" = [0.5, 1.0]\n')


@pytest.fixture(scope="module")
def studies(tmp_path_factory):
    """A complete fit and sensitivity study (whose runs/ is a sweep), shared by the ranks."""
    return small_studies(tmp_path_factory.mktemp("damage") if COMM.rank == 0 else None)


def small_studies(root: Path | None) -> Path:
    """A complete fit (fit/) and sensitivity study (sensitivity/) of a few runs of 8 cells in
    ``root`` (rank 0's; every rank gets it back)."""
    root = COMM.bcast(root, root=0)
    if COMM.rank == 0:
        (root / "data.csv").write_text(DATA)
        (root / "fit.toml").write_text(SMALL_FIT)
        (root / "sens.toml").write_text(SENSITIVITY)
    COMM.barrier()
    assert main(["fit", str(root / "fit.toml"), "--out", str(root / "fit"), "--quiet"]) == 0
    assert main(["sensitivity", str(root / "sens.toml"), "--out", str(root / "sensitivity"),
                 "--quiet"]) == 0
    return root


def _stopped(source: Path, out: Path) -> None:
    """``out``: a copy of the study ``source`` as a signal before its last phase leaves it."""
    shutil.copytree(source, out, symlinks=True)
    for directory in (out, out / "runs"):
        if (directory / "rodfem.json").exists():
            marker = json.loads((directory / "rodfem.json").read_text())
            marker["status"] = "interrupted" if directory == out else marker["status"]
            (directory / "rodfem.json").write_text(json.dumps(marker))
    for name in ("fit.json", "fit.png", "sensitivity.csv", "sensitivity.png"):
        (out / name).unlink(missing_ok=True)
    shutil.rmtree(out / "fitted", ignore_errors=True)


def _journal_a_file(out):
    shutil.rmtree(out / "journal")
    (out / "journal").write_text("mine")


def _marker_says(command, where="."):
    def edit(out):
        marker = out / where / "rodfem.json"
        marker.write_text(marker.read_text().replace(
            f'"command": "{json.loads(marker.read_text())["command"]}"', f'"command": "{command}"'))
    return edit


def _replaced_by_a_directory(name):
    def replace(out):
        (out / name).unlink()
        (out / name).mkdir()
    return replace


CASES = {
    "fit journal a file": ("fit", _journal_a_file,
                           "journal is a file, where 'rodfem fit' keeps a directory"),
    "fit empty fitted/": ("fit", lambda out: (out / "fitted").mkdir(),
                          "fitted is not the directory rodfem writes there (it has no "
                          "rodfem.json); move it away and resume again"),
    "fit study.json removed": ("fit", lambda out: (out / "study.json").unlink(),
                               "is damaged: study.json is missing, though its journal/ holds "
                               "points; put study.json back, or run the fit again with --force"),
    "fit data.csv a link": ("fit", lambda out: ((out / "data.csv").unlink(),
                                                (out / "data.csv").symlink_to("fit.toml")),
                            "data.csv is a link, where 'rodfem fit' keeps a file"),
    "sensitivity marker says fit": ("sensitivity", _marker_says("fit"),
                                    "says it is a directory of 'rodfem fit', but it holds "
                                    "sensitivity.json, a file of 'rodfem sensitivity': the "
                                    "marker disagrees with the directory's files"),
    "sensitivity runs/ marker says run": ("sensitivity", _marker_says("run", "runs"),
                                          "runs/rodfem.json says it is a directory of 'rodfem "
                                          "run', not of 'rodfem sweep'"),
    "sensitivity results.csv a directory": ("sensitivity",
                                            _replaced_by_a_directory("runs/results.csv"),
                                            "results.csv is a directory, where 'rodfem sweep' "
                                            "keeps a file"),
    "sweep summary.json a directory": ("sweep", _replaced_by_a_directory("summary.json"),
                                       "summary.json is a directory, where 'rodfem sweep' keeps "
                                       "a file"),
    "sweep sweep.json removed": ("sweep", lambda out: (out / "sweep.json").unlink(),
                                 "is damaged: sweep.json is missing, though it holds results.csv"),
    "sweep marker says run": ("sweep", _marker_says("run"),
                              "but it holds sweep.json, a file of 'rodfem sweep'"),
}


def _snapshot(out: Path) -> dict:
    """Every entry under ``out`` (but the lock): its kind and bytes."""
    found = {}
    for path in sorted(out.rglob("*")):
        if path.name != "rodfem.lock":
            found[str(path.relative_to(out))] = (
                "link" if path.is_symlink() else "dir" if path.is_dir() else path.read_bytes())
    return found


@pytest.mark.parametrize("case", sorted(CASES))
def test_an_altered_study_is_refused_before_anything_is_done(case, studies, capsys):
    kind, alter, message = CASES[case]
    out = studies / case.replace(" ", "-").replace("/", "")
    if COMM.rank == 0:
        source = studies / ("sensitivity" / Path("runs") if kind == "sweep" else kind)
        _stopped(source, out)
        alter(out)
    COMM.barrier()
    before = _snapshot(out)
    capsys.readouterr()
    assert main(["resume", str(out)]) == 2
    err = capsys.readouterr().err
    if COMM.rank == 0:
        assert err.startswith("rodfem: error: ") and err.count("\n") == 1, err
        assert message in err, err
    COMM.barrier()
    assert _snapshot(out) == before
    assert os.path.exists(out / "rodfem.json")
