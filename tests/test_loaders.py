"""Each loader reads its own kind of directory, and names any other kind in one line with the
loader that reads it (the command in its marker, rodfem.json): ``rodfem.load`` of a sweep
directory says "… is a sweep directory: use rodfem.load_sweep", not the file it lacks.
Serially and under mpirun (every rank loads)."""

import re

import pytest
from test_study_damage import small_studies

import rodfem
from conftest import COMM
from rodfem.cli import main
from rodfem.output.readers import RunDirectoryError
from rodfem.output.results import ResultsError

# Each loader, the kind it reads, what it gives and what it raises for another kind.
LOADERS = {"load": ("run", "Result", RunDirectoryError),
           "load_sweep": ("sweep", "SweepResult", ResultsError),
           "load_fit": ("fit", "FitResult", rodfem.SceneError),
           "load_sensitivity": ("sensitivity", "SensitivityResult", rodfem.SceneError)}
LOADER_OF = {kind: name for name, (kind, _, _) in LOADERS.items()}
KINDS = ("run", "sweep", "fit", "sensitivity", "steady")
OTHERS = [(loader, kind) for loader in LOADERS for kind in KINDS if kind != LOADERS[loader][0]]


@pytest.fixture(scope="module")
def directories(tmp_path_factory):
    """A directory of each kind, small and short, shared by the ranks: a fit (whose fitted/ is a
    run), a sensitivity study (whose runs/ is a sweep) and the steady states of a scene."""
    root = small_studies(tmp_path_factory.mktemp("kinds") if COMM.rank == 0 else None)
    assert main(["steady", "paper1", "--set", "mesh.cells=8", "--out", str(root / "steady")]) == 0
    return {"run": root / "fit" / "fitted", "sweep": root / "sensitivity" / "runs",
            "fit": root / "fit", "sensitivity": root / "sensitivity", "steady": root / "steady"}


@pytest.mark.parametrize("loader", LOADERS)
def test_each_loader_reads_its_own_kind(loader, directories):
    kind, given, _ = LOADERS[loader]
    result = getattr(rodfem, loader)(directories[kind])
    assert isinstance(result, getattr(rodfem, given))
    assert result.path == directories[kind]


@pytest.mark.parametrize(("loader", "kind"), OTHERS)
def test_each_loader_names_the_loader_of_another_kind(loader, kind, directories):
    error = LOADERS[loader][2]
    path = directories[kind]
    with pytest.raises(error) as raised:
        getattr(rodfem, loader)(path)
    if kind == "steady":
        said = (f"{path} is a steady-state directory (rodfem steady), which no loader reads: "
                "only run, sweep, fit and sensitivity directories load")
    else:
        said = f"{path} is a {kind} directory: use rodfem.{LOADER_OF[kind]}"
    assert str(raised.value) == said


def test_a_directory_without_a_marker_is_refused_as_before(directories, tmp_path_factory):
    """Without rodfem.json nothing names the kind: each loader says what it lacks."""
    empty = COMM.bcast(tmp_path_factory.mktemp("empty") if COMM.rank == 0 else None, root=0)
    with pytest.raises(RunDirectoryError, match=re.escape("has no scene.toml or rodfem.json")):
        rodfem.load(empty)
    with pytest.raises(ResultsError, match="results.csv"):
        rodfem.load_sweep(empty)
    with pytest.raises(rodfem.SceneError, match="fit.json"):
        rodfem.load_fit(empty)
    with pytest.raises(rodfem.SceneError, match="sensitivity.json"):
        rodfem.load_sensitivity(empty)
