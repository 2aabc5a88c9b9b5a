"""``rodfem prepare`` (what ``make setup`` runs): after it, the first run of every built-in scene,
with fixed or adaptive steps (but the manufactured scenes' adaptive ones, whose new step sizes
are formed through dolfinx), compiles nothing and assembles nothing new. Each test has caches
of its own ($XDG_CACHE_HOME in a temporary directory), so that it starts as a fresh machine."""

import os
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest
from conftest import representative, serial_only

from rodfem.scene import BUILTIN, EXTRA

pytestmark = serial_only  # each test starts processes of its own

RUNS = """
import sys, warnings
from pathlib import Path
import rodfem
from rodfem.api import scene_of
warnings.simplefilter("ignore")
for name in sys.argv[2:]:
    dt = scene_of(name)["time.dt"]
    # the manufactured scenes' sources have no compiled step family yet: their adaptive steps
    # form each new size's operators through dolfinx, with Δt in the forms
    for adaptive in ("false",) if name.startswith("manufactured") else ("false", "true"):
        r = rodfem.simulate(name, [f"time.adaptive={adaptive}", f"time.end={2 * dt!r}"],
                            out=Path(sys.argv[1]) / name, force=True)
        assert r.status == "complete", (name, adaptive, r.status)
"""


def python(*arguments, cache: Path, cwd: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ, XDG_CACHE_HOME=str(cache))
    return subprocess.run([sys.executable, *arguments], capture_output=True, text=True, env=env,
                          cwd=cwd, timeout=600)


def cached(cache: Path) -> dict[str, int | None]:
    """Every file of the caches, with its modification time (but the operators', which a run
    that reads them touches: the cache keeps the recently used)."""
    return {str(p.relative_to(cache)): None if p.name.startswith("operators-")
            else p.stat().st_mtime_ns for p in cache.rglob("*")
            if p.is_file() and p.name != "build.lock"}


# The quick profile prepares three scenes of different families (the paper's, the impact's
# redistributed mass, a manufactured scene's sources), the full one every built-in scene.
SOME = ("paper1", "impact", "manufactured")


@pytest.mark.parametrize("chosen", representative(["every", "some"], ["some"]))
def test_after_prepare_no_built_in_scene_compiles_or_assembles_anything(tmp_path, chosen):
    cache = tmp_path / "cache"
    names = (*BUILTIN, *EXTRA) if chosen == "every" else SOME
    named = () if chosen == "every" else names  # with no name, prepare takes every one
    done = python("-m", "rodfem", "prepare", *named, cache=cache, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    for name in names:
        assert f"prepared {name} (" in done.stdout
    before = cached(cache)
    assert any(name.startswith("fenics/") for name in before)  # the forms, compiled
    assert any(name.startswith("rodfem/operators-") for name in before)
    assert not any(tmp_path.glob("rodfem-prepare-*"))
    done = python("-c", RUNS, str(tmp_path / "runs"), *names, cache=cache, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert cached(cache) == before


def test_prepare_takes_a_users_scene_and_refuses_a_wrong_name_before_running(tmp_path):
    scene = tmp_path / "mine.toml"
    scene.write_text('scene = "paper1"\n[mesh]\ncells = 40\n')
    cache = tmp_path / "cache"
    done = python("-m", "rodfem", "prepare", str(scene), "--quiet", cache=cache, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert done.stdout == ""
    operators = {n for n in cached(cache) if n.startswith("rodfem/operators-")}
    assert operators
    done = python("-m", "rodfem", "prepare", "paper1", "nosuch", cache=tmp_path / "other",
                  cwd=tmp_path)
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "nosuch" in lines[0] and "paper1" in lines[0], done.stderr
    assert not (tmp_path / "other").exists()  # refused before anything was run


@pytest.mark.slow  # the operator cache's own tests compare histories with and without it
def test_a_prepared_scene_runs_to_the_same_history_as_an_unprepared_one(tmp_path):
    """The operators prepare cached are the ones a run would assemble: the same history."""
    cells = 40
    overrides = [f"mesh.cells={cells}", "time.end=0.02"]
    scene = tmp_path / "mine.toml"
    scene.write_text(f'scene = "paper1"\n[mesh]\ncells = {cells}\n')
    cache = tmp_path / "cache"
    histories = []
    for prepared in (False, True):
        if prepared:
            done = python("-m", "rodfem", "prepare", str(scene), "--quiet", cache=cache,
                          cwd=tmp_path)
            assert done.returncode == 0, done.stderr
        out = tmp_path / f"run{int(prepared)}"
        done = python("-m", "rodfem", "run", "paper1", *[f"--set={o}" for o in overrides],
                      "--out", str(out), "--quiet", cache=cache if prepared else tmp_path / "c0",
                      cwd=tmp_path)
        assert done.returncode == 0, done.stderr
        with h5py.File(out / "history.h5") as f:
            histories.append(np.asarray(f["history"]))
    assert histories[0].shape[0] == 21  # the steps 0 .. 20
    assert np.array_equal(*histories)
