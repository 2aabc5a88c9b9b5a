"""``rodfem plot``: every figure is written, is an image and is not blank, for one run and for two
runs overlaid; the fields read back agree with history.h5 and with the definitions of θ and σ;
a directory that is not a run gets exit code 2, one line, and nothing written.

Runs are simulated collectively (as the suite also runs under mpirun); figures are drawn and
checked on rank 0, except through the command, which every rank calls.
"""

import shutil
import tempfile
from pathlib import Path

import numpy as np
import pytest
from PIL import Image, ImageSequence

import rodfem.scene
from conftest import COMM
from rodfem.cli import main

END, EVERY = "time.end=0.5", "output.every=25"
STILLS = ("contact", "energy", "spacetime_u", "spacetime_theta", "spacetime_sigma")


@pytest.fixture(scope="module")
def runs():
    """paper1 (ζ = 0.2) and paper2 (ζ = 1) to t = 0.5: the rod reaches the obstacle at t ≈ 0.2."""
    from rodfem.output.directories import prepare_directory
    from rodfem.run import simulate

    root = Path(tempfile.mkdtemp(prefix="rodfem-plot-")) if COMM.rank == 0 else None
    root = COMM.bcast(root, root=0)
    dirs = []
    for name in ("paper1", "paper2"):
        out = root / name
        prepare_directory(out, False, COMM)
        simulate(rodfem.scene.load(name, [END, EVERY]), out, COMM, progress=False)
        dirs.append(out)
    yield dirs
    COMM.barrier()
    if COMM.rank == 0:
        shutil.rmtree(root, ignore_errors=True)


def frames(path: Path) -> list[np.ndarray]:
    """The RGB frames of an image file, read back with Pillow (which checks the format)."""
    with Image.open(path) as image:
        return [np.asarray(frame.convert("RGB")) for frame in ImageSequence.Iterator(image)]


def assert_figure(path: Path, size: tuple[int, int] | None = None) -> None:
    images = frames(path)
    for image in images:
        colours = image.reshape(-1, 3).astype(np.uint32) @ np.array([1 << 16, 1 << 8, 1],
                                                                    dtype=np.uint32)
        assert image.std() > 10 and np.unique(colours).size > 16, f"{path.name} is blank"
        if size is not None:
            assert image.shape[1::-1] == size


def assert_animation(path: Path, saves: int) -> None:
    from rodfem.post.animation import frame_indices

    images = frames(path)
    assert len(images) == len(frame_indices(saves)) > 1
    assert any(not np.array_equal(images[0], image) for image in images[1:]), "the rod never moves"
    assert path.stat().st_size < 5e6
    assert_figure(path)


def test_one_run(runs):
    if COMM.rank != 0:
        return
    from rodfem.post import load_run, plot

    run = runs[0]
    written = plot([run], None)
    expected = [run / "figures" / f"{name}.png" for name in STILLS] + [run / "figures/rod.gif"]
    assert sorted(written) == sorted(expected)
    for path in expected[:-1]:
        assert_figure(path, size=(1200, 900))
    assert_animation(expected[-1], load_run(run).fields.t.size)

    # The panels shade u(1) > g (from t ≈ 0.2 to 0.5 here, 60 % of each panel's width) in
    # matplotlib's grey "0.87" = 222/255.
    assert shaded(run / "figures/contact.png") > 0.1


def shaded(path: Path) -> float:
    """The fraction of a figure's pixels in the grey of contact intervals (style.CONTACT_SHADE)."""
    image = frames(path)[0].astype(int)
    return float((np.abs(image - round(0.87 * 255)).max(axis=2) <= 1).mean())


def test_two_runs_overlaid_through_the_command(runs, capsys):
    out = runs[0].parent / "compare"
    code = main(["plot", *map(str, runs), "--out", str(out)])
    captured = capsys.readouterr()
    assert code == 0
    if COMM.rank != 0:
        return
    names = ["contact.png", "energy.png"]
    for run in ("paper1", "paper2"):
        names += [f"{still}_{run}.png" for still in STILLS[2:]] + [f"rod_{run}.gif"]
    assert captured.out.splitlines() == [str(out / name) for name in names]
    for name in names:
        if name.endswith(".png"):
            assert_figure(out / name, size=(1200, 900))
        else:
            assert_animation(out / name, 21)
    # Overlaid, contact is not shaded: it is seen against the gap line (grey only in the grid
    # lines, "0.9", and the antialiased edges of text and curves).
    assert shaded(out / "contact.png") < 0.002


def test_fields_read_back(runs):
    """u(1) matches history.h5 at the saved steps; θ(0) = θ_A; at t = 0, where u₀ = 0 and
    u_t = u₁ = 20x(x − 1)², σ = ζ (u₁)_x − aθ̄ per cell (θ̄ the cell mean of the P1 θ)."""
    if COMM.rank != 0:
        return
    from rodfem.post import load_run

    run = load_run(runs[0])
    f, h = run.fields, run.history
    assert np.all(np.diff(f.x) > 0) and f.x[0] == 0.0 and f.x[-1] == 1.0
    assert f.t.size == 21 and f.theta.shape == f.u.shape == (21, f.x.size)
    assert f.sigma.shape == (21, f.x.size - 1)
    np.testing.assert_allclose(f.x_cells, 0.5 * (f.x[1:] + f.x[:-1]), rtol=0, atol=1e-15)

    saved = np.rint(f.t / run.scene["time.dt"]).astype(int)
    np.testing.assert_array_equal(saved, np.arange(0, 501, 25))
    np.testing.assert_allclose(h.t[saved], f.t, rtol=0, atol=1e-12)
    np.testing.assert_allclose(f.u[:, -1], h.u_1[saved], rtol=0, atol=1e-12)
    assert (h.u_1[saved] > run.gap).any(), "the run should reach the obstacle"

    zeta, a, theta_A = (run.scene[k] for k in ("model.zeta", "model.a", "model.theta_A"))
    np.testing.assert_allclose(f.theta[:, 0], theta_A, rtol=0, atol=1e-12)
    u1 = 20 * f.x * (f.x - 1) ** 2
    sigma0 = zeta * np.diff(u1) / np.diff(f.x) - a * 0.5 * (f.theta[0][1:] + f.theta[0][:-1])
    np.testing.assert_allclose(f.sigma[0], sigma0, rtol=1e-12, atol=1e-12)


def _not_a_run(root: Path, case: str) -> Path:
    path = root / case
    if case == "missing":
        return path
    path.mkdir()
    if case == "bad-header":
        for name in ("scene.toml", "fields.xdmf"):
            (path / name).write_text("")
        (path / "history.csv").write_text("time,u\n0,0\n")  # an earlier rodfem's history
    if case == "junk-history":
        for name in ("scene.toml", "fields.xdmf"):
            (path / name).write_text("")
        (path / "history.h5").write_bytes(b"junk" * 100)
    return path


@pytest.mark.parametrize("case, message", [
    ("missing", "is not a directory"),
    ("empty", "is not a rodfem run directory (it has no history.h5)"),
    ("bad-header", "is not a rodfem history"),
    ("junk-history", "cannot read"),
])
def test_not_a_run_directory(case, message, runs, shared_dir, capsys):
    bad = _not_a_run(shared_dir, case) if COMM.rank == 0 else None
    bad = COMM.bcast(bad, root=0)
    out = shared_dir / "figures"
    code = main(["plot", str(runs[0]), str(bad), "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2
    if COMM.rank == 0:
        assert err.startswith("rodfem: error: ") and err.count("\n") == 1
        assert message in err and "Traceback" not in err
    assert not out.exists(), "nothing is written when a directory is bad"


def test_frames_and_scale():
    from rodfem.post.animation import MAX_FRAMES, displacement_scale, frame_indices

    for count in (1, 2, 51, MAX_FRAMES, MAX_FRAMES + 1, 161, 8001):
        k = frame_indices(count)
        assert k[0] == 0 and k[-1] == count - 1 and len(k) <= MAX_FRAMES
        assert np.all(np.diff(k) > 0)
    x = np.linspace(0, 1, 11)
    assert displacement_scale(x, np.array([0.4 * x])) == 1.0
    assert displacement_scale(x, np.array([-1.5 * x])) == 0.2  # 0.5 / 1.5 → 0.2
