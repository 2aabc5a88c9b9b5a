"""rodfem paper: five experiments, their figures and an index that quotes the paper beside them
and links every figure written, none blank; and every experiment's literate demo runs under
mpirun -n 2."""

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from test_plot import assert_figure

from conftest import COMM, representative, serial_only
from rodfem.cli import main
from rodfem.studies.verification.paper import EXPERIMENTS

ROOT = Path(__file__).resolve().parents[1]


def test_paper_index_sets_each_figure_beside_the_paper(shared_dir, capsys):
    out = shared_dir / "paper"
    code = main(["paper", "--out", str(out), "--set", "time.end=0.2", "--set", "output.every=20"])
    capsys.readouterr()
    assert code == 0
    if COMM.rank != 0:
        return
    index = (out / "index.md").read_text(encoding="utf-8")
    for experiment in EXPERIMENTS:
        assert experiment.says in index
        assert (out / experiment.scene / "history.h5").is_file()
    images = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", index)
    assert len(images) == 6 * len(EXPERIMENTS) + 2
    drawn = sorted(p.relative_to(out).as_posix() for p in out.rglob("*")
                   if p.suffix in (".png", ".gif"))
    assert sorted(images) == drawn  # every figure written is linked, and only those
    for image in images:
        assert_figure(out / image)  # every frame of every figure has something drawn
    assert "ln(Ê^n + 0.01)" in index and "figure5/energy.png" in images
    # t ≤ 0.2: paper1 touches once (from t ≈ 0.19), singular; no count of 1 in the plural
    assert "rodfem: 1 interval of contact (u(1) > g)" in index
    assert not re.search(r"\b1 intervals", index)


def test_plural():
    from rodfem.studies.verification.paper import plural

    assert [plural(n, "interval") for n in (0, 1, 2)] == ["0 intervals", "1 interval",
                                                           "2 intervals"]


def test_paper_refuses_a_bad_override_before_running(shared_dir, capsys):
    out = shared_dir / "paper"
    assert main(["paper", "--out", str(out), "--set", "model.zetta=1"]) == 2
    assert not out.exists()
    capsys.readouterr()


@serial_only
@pytest.mark.skipif(shutil.which("mpirun") is None, reason="needs mpirun")
@pytest.mark.parametrize("demo", representative([f"demo_paper{i}" for i in range(2, 6)],
                                                ["demo_paper5"]))
def test_experiment_demos_run_under_mpirun(tmp_path, demo):
    env = {**os.environ, "OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1"}
    done = subprocess.run(
        ["mpirun", "-n", "2", sys.executable, str(ROOT / "demos" / f"{demo}.py"),
         "--out", str(tmp_path / "run"), "--end", "0.3"],
        env=env, capture_output=True, text=True, timeout=600, check=True,
    )
    assert done.stdout.count("Energy non-increasing: yes") == 1  # rank 0 reports, once
    assert (tmp_path / "run" / "figures" / "contact.png").is_file()
    assert (tmp_path / "run" / "figures" / "rod.gif").is_file()
