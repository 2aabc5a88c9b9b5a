"""A stop signal is taken in every phase of a study, the last ones too (the analysis after the
runs, the fitted run, the figures): exit code 128 + n, the directory interrupted, and resume
finishes it to the files of a study never stopped. Serially and under mpirun, where the signal
reaches rank 0 alone (which draws) and every rank stops alike."""

import os
import signal

import pytest

import rodfem
from conftest import COMM
from rodfem.cli import main
from rodfem.output import interrupts
from rodfem.output.directories import state

SMALL_FIT = ('scene = "paper1"\ndata = "data.csv"\nmax_evaluations = 2\n[set]\n'
             '"mesh.cells" = 8\n"time.dt" = 0.002\n"time.end" = 0.2\n"solver.method" = "direct"\n'
             '"obstacle.epsilon" = 0.012\n[parameters]\n"model.zeta" = [0.1, 1.0]\n')
DATA = "t,u_1\n0.05,0.002\n0.1,0.004\n0.2,0.005\n"


@pytest.fixture(scope="module")
def unstopped(tmp_path_factory):
    """A small fit file and the directory of its fit, never stopped (shared by the ranks)."""
    root = COMM.bcast(tmp_path_factory.mktemp("fit") if COMM.rank == 0 else None, root=0)
    if COMM.rank == 0:
        (root / "data.csv").write_text(DATA)
        (root / "fit.toml").write_text(SMALL_FIT)
    COMM.barrier()
    assert main(["fit", str(root / "fit.toml"), "--out", str(root / "whole"), "--quiet"]) == 0
    return root


def _signalled(function):
    """``function``, sending this process SIGTERM first."""
    def signalled(*args, **kwargs):
        os.kill(os.getpid(), signal.SIGTERM)
        return function(*args, **kwargs)
    return signalled


@pytest.mark.parametrize("phase", ["statistics", "fitted run", "figure"])
def test_a_signal_after_the_optimiser_stops_the_fit_and_resume_finishes_it(
        phase, unstopped, capsys, monkeypatch):
    """SIGTERM in the statistics at the optimum, or as fit.png was drawn, was let wait: the fit
    ended complete, exit 0. It now stops there, exit 143, no fit.json, and resume replays the
    journal to the same fit.json and fit.png."""
    import rodfem.post.fit as chart
    from rodfem.studies.fit import run as fitrun

    monkeypatch.setattr(interrupts, "_received", [])  # the signal is this test's alone
    module, name = {"statistics": (fitrun, "statistics"), "fitted run": (fitrun, "_fitted"),
                    "figure": (chart, "plot_fit")}[phase]
    monkeypatch.setattr(module, name, _signalled(getattr(module, name)))
    out = unstopped / f"out-{phase.replace(' ', '-')}"
    capsys.readouterr()
    assert main(["fit", str(unstopped / "fit.toml"), "--out", str(out)]) == 143
    COMM.barrier()  # rank 0 marks the directory as the others end
    err = capsys.readouterr().err
    if COMM.rank == 0:
        assert err.startswith("rodfem: interrupted by SIGTERM") and err.count("\n") == 1, err
        assert f"'rodfem resume {out}' continues it" in err
    assert state(out) == "interrupted" and not (out / "fit.json").exists()
    monkeypatch.undo()
    interrupts._received.clear()
    assert main(["resume", str(out), "--quiet"]) == 0
    COMM.barrier()
    assert state(out) == "complete"
    for name in ("fit.json", "fit.png"):
        assert (out / name).read_bytes() == (unstopped / "whole" / name).read_bytes(), name
    assert rodfem.load_fit(out).fitted.history["u_1"].tolist() == \
        rodfem.load_fit(unstopped / "whole").fitted.history["u_1"].tolist()
