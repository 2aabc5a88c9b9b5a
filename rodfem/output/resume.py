"""What ``rodfem resume DIR`` continues: the run's own scene, from its checkpoint.

A run continues only as it was run: the scene of its checkpoint (``scene.toml``, unchanged), on
as many MPI ranks, from the checkpoint's step, so that its history and fields come out bit for bit
as an uninterrupted run's. The one change allowed is ``time.end``: a later end extends the run.
"""

from __future__ import annotations

from pathlib import Path

from rodfem.output.checkpoint import NAME, CheckpointError, check_counted, read_checkpoint
from rodfem.output.sizes import save_every
from rodfem.scene import SceneError, load, validate

CHANGEABLE = ("time.end",)


class ResumeError(ValueError):
    """The run cannot be continued (exit code 2, nothing touched)."""


def identity(data: dict) -> dict:
    """A scene's values without those a resumed run may change."""
    data = {section: dict(values) if isinstance(values, dict) else values
            for section, values in data.items()}
    for key in CHANGEABLE:
        section, name = key.split(".")
        data.get(section, {}).pop(name, None)
    return data


def _resolved(data: dict) -> dict:
    """A checkpoint's scene with the defaults of keys added since it was written (a run of an
    earlier rodfem resumes); as it is where it is not a valid scene."""
    try:
        return validate(data).data()
    except SceneError:
        return data


def _plan(out: Path, overrides: list[str], marker: dict, ranks: int):
    for item in overrides:
        key = item.split("=", 1)[0].strip()
        if key not in CHANGEABLE:
            raise ResumeError(f"--set {item}: a resumed run keeps its scene; only "
                              f"{', '.join(CHANGEABLE)} can be changed")
    if not (out / "scene.toml").is_file():
        raise ResumeError(f"{out} has no scene.toml: the run was stopped before it began; run it "
                          "again (rodfem run ... --force)")
    try:
        base = load(str(out / "scene.toml"))
        scene = load(str(out / "scene.toml"), overrides)
    except SceneError as err:
        raise ResumeError(str(err)) from None
    if not (out / NAME).exists():
        return scene, None
    try:
        arrays, meta = read_checkpoint(out)
    except CheckpointError as err:
        raise ResumeError(str(err)) from None
    if identity(_resolved(meta.get("scene", {}))) != identity(base.data()):
        raise ResumeError(f"{out / 'scene.toml'} is not the scene of the run's checkpoint (was "
                          "it edited?); a run resumes with the scene it was run with")
    if meta.get("mpi_ranks") != ranks:
        raise ResumeError(f"the run was made on {meta.get('mpi_ranks')} MPI rank(s); resume it "
                          f"on as many (mpirun -n {meta.get('mpi_ranks')}), for the same result "
                          "bit for bit")
    step, steps = meta["step"], scene.steps
    if steps < step:
        raise ResumeError(f"time.end = {scene['time.end']:g} is before the checkpoint's "
                          f"t = {step * scene['time.dt']:g}")
    if steps == step and marker.get("status") == "complete":
        raise ResumeError(f"the run is complete at t = {scene['time.end']:g}; --set time.end=T "
                          "extends it")
    _check_files(out, meta)
    every = save_every(scene)
    # Saves off the schedule (the last step of an interrupted or finished run) are not an
    # uninterrupted run's: they are dropped (their rows stay in their segments, unlisted).
    meta["saves"] = [s for s in meta["saves"] if s[0] % every == 0]
    meta["scene"] = scene.data()
    return scene, (arrays, meta)


def _check_files(out: Path, meta: dict) -> None:
    """The files the checkpoint counts are there as it left them (:func:`check_counted`)."""
    try:
        check_counted(out, meta)
    except CheckpointError as err:
        raise ResumeError(str(err)) from None
    if len(meta["digests"]["segments"]) != meta["segments"]:
        raise ResumeError(f"{out / NAME} counts {meta['segments']} segments of fields but holds "
                          f"the digests of {len(meta['digests']['segments'])}")


def plan(out: Path, overrides: list[str], marker: dict, comm):
    """The scene and checkpoint (arrays, metadata) to resume ``out`` from, on every rank; the
    checkpoint is None if the run has none yet (it starts again). ResumeError otherwise."""
    result, error = None, None
    if comm.rank == 0:
        try:
            scene, checkpoint = _plan(Path(out), list(overrides), marker, comm.size)
            if overrides:
                from rodfem.output.atomic import replacing

                with replacing(Path(out) / "scene.toml") as file:
                    file.write(scene.to_toml())
            source = checkpoint[1].get("source", scene.source) if checkpoint else scene.source
            result = (scene.data(), source, checkpoint)
        except ResumeError as err:
            error = str(err)
        except OSError as err:
            error = f"cannot resume {out}: {err.strerror or err}"
    result, error = comm.bcast((result, error), root=0)
    if error:
        raise ResumeError(error)
    from rodfem.scene import validate

    data, source, checkpoint = result
    return validate(data, source), checkpoint
