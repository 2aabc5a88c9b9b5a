"""What ``rodfem resume DIR`` continues: the run's own scene, from its checkpoint.

A run continues only as it was run: the scene of its checkpoint (``scene.toml``, unchanged), on
as many MPI ranks, from the checkpoint's step, so that its history and fields come out bit for bit
as an uninterrupted run's. The one change allowed is ``time.end``: a later end extends the run.
"""

from __future__ import annotations

from pathlib import Path

from rodfem.output.checkpoint import NAME, CheckpointError, check_counted, read_checkpoint
from rodfem.output.sizes import scheduled
from rodfem.scene import SceneError, load, validate

CHANGEABLE = ("time.end",)


class ResumeError(ValueError):
    """The run cannot be continued (exit code 2, nothing touched)."""

    code = 2

    def line(self) -> str:
        """What ``rodfem resume`` says, on one line."""
        return f"rodfem: error: {self}"


class Complete(ResumeError):
    """Nothing to continue: the run is complete (exit code 0, nothing touched), so that a job
    script that always resumes after a requeue does not fail."""

    code = 0

    def line(self) -> str:
        return f"rodfem: {self}"


class Unrunnable(ResumeError):
    """The loop the run needs cannot be built here (exit code 3, nothing changed:
    :class:`rodfem.solver.compiled.KernelUnavailable`)."""

    code = 3

    def line(self) -> str:
        return str(self)


class WriteError(ResumeError):
    """The scene of an extended run could not be written (exit code 4: a full disk; the run's
    files unchanged)."""

    code = 4


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


def _plan(out: Path, overrides: list[str], marker: dict, ranks: int, large: bool,
          any_loop: bool):
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
        _check_room(scene, out, 0, large)
        return scene, None
    try:
        arrays, meta = read_checkpoint(out)
    except CheckpointError as err:
        raise ResumeError(str(err)) from None
    _check_same_run(out, scene, base, arrays, meta, ranks)
    if not any_loop:
        _check_same_loop(meta, scene)
    step, steps = meta["step"], scene.steps
    reached = float(arrays["controller"][0]) if "controller" in arrays else step * scene["time.dt"]
    ended = reached >= scene["time.end"] if "controller" in arrays else steps == step
    if (steps < step if "controller" not in arrays else reached > scene["time.end"]):
        raise ResumeError(f"time.end = {scene['time.end']:g} is before the checkpoint's "
                          f"t = {reached:g}")
    if ended and marker.get("status") == "complete":
        raise Complete(f"{out} is a complete run (t = {scene['time.end']:g}); nothing was "
                       f"changed ('rodfem resume {out} --set time.end=T' extends it)")
    _check_files(out, meta)
    _check_room(scene, out, _written(out, meta), large)
    # Saves off the schedule (the last step of an interrupted or finished run) are not an
    # uninterrupted run's: they are dropped (their rows stay in their segments, unlisted).
    meta["saves"] = scheduled(meta["saves"], scene)
    meta["scene"] = scene.data()
    return scene, (arrays, meta)


def _check_same_run(out: Path, scene, base, arrays: dict, meta: dict, ranks: int) -> None:
    """The checkpoint is this run's: of its scene, on as many ranks, of its method."""
    if identity(_resolved(meta["scene"])) != identity(base.data()):
        raise ResumeError(f"{out / 'scene.toml'} is not the scene of the run's checkpoint (was "
                          "it edited?); a run resumes with the scene it was run with")
    if meta["mpi_ranks"] != ranks:
        raise ResumeError(f"the run was made on {meta['mpi_ranks']} MPI rank(s); resume it "
                          f"on as many (mpirun -n {meta['mpi_ranks']}), for the same result "
                          "bit for bit")
    newton = scene["solver.method"] == "newton"  # the one method with a state of its own
    if ("guess" in arrays) != newton or ("controller" in arrays) != scene.adaptive or (
            ranks == 1 and arrays["u_prev"].size != scene["mesh.cells"] + 1):
        raise ResumeError(f"{out / NAME} is not a checkpoint of the scene in "
                          f"{out / 'scene.toml'}; the run cannot continue from it")


def _check_same_loop(meta: dict, scene) -> None:
    """The steps still to take are made by the loop that made the run's steps so far (the
    compiled loop of the same arithmetic, or the PETSc loop): a history of one arithmetic. A
    checkpoint that does not record its loop (an earlier rodfem's) continues with this one."""
    from rodfem.solver.compiled import PETSC, UNRECORDED, loop_name

    recorded = (meta.get("loops") or [[0, UNRECORDED]])[-1][1]
    now = loop_name(scene)
    if recorded in (now, UNRECORDED):
        return
    if now == PETSC and recorded.startswith("compiled"):
        how = ("resume it without RODFEM_KERNEL=0" if _kernel_off() else
               "its compiled loop does not apply here")
    elif recorded == PETSC:
        how = "resume it with RODFEM_KERNEL=0 to keep the PETSc loop"
    else:
        how = "the compiled loop's C sources or compiler changed since (another rodfem?)"
    raise ResumeError(f"the run's steps were made by the {_said(recorded)}, and this resume "
                      f"would make the rest with the {_said(now)}, whose last digits differ; "
                      f"{how}, or give --any-loop to continue with two loops in one history")


def _kernel_off() -> bool:
    import os

    return os.environ.get("RODFEM_KERNEL", "1") == "0"


def _said(loop: str) -> str:
    """A loop's name (:func:`rodfem.solver.compiled.loop_name`) in a sentence."""
    if loop.startswith("compiled "):
        _, kind, digest = (loop.split() + ["", ""])[:3]
        return f"compiled {kind} loop ({digest})"
    return "PETSc loop" if loop == "petsc" else f"loop {loop!r}"


def _written(out: Path, meta: dict) -> int:
    """The bytes a run has written up to its checkpoint (its history and fields; the files
    :func:`check_counted` found whole)."""
    from rodfem.output.fields import DIRECTORY
    from rodfem.output.readers import HISTORY

    fields = sum(f.stat().st_size for f in (out / DIRECTORY).glob("*.h5") if f.is_file())
    return (out / HISTORY).stat().st_size + fields


def _check_room(scene, out: Path, already: int, large: bool) -> None:
    """The size check of ``rodfem run``, for what the run has still to write."""
    from rodfem.output.sizes import room_error

    error = None if large else room_error(scene, out, already)
    if error is not None:
        raise ResumeError(error)


def _check_files(out: Path, meta: dict) -> None:
    """The files the checkpoint counts are there as it left them (:func:`check_counted`)."""
    try:
        check_counted(out, meta)
    except CheckpointError as err:
        raise ResumeError(str(err)) from None


def plan(out: Path, overrides: list[str], marker: dict, comm, large: bool = False,
         any_loop: bool = False):
    """The scene and checkpoint (arrays, metadata) to resume ``out`` from, on every rank; the
    checkpoint is None if the run has none yet (it starts again). Everything is checked before
    anything is written, the compiled loop the run uses built on every rank: ResumeError (or its
    kinds :class:`Complete`, :class:`Unrunnable`, :class:`WriteError`, with their exit codes)
    otherwise, with nothing changed. ``large``: no size check. ``any_loop``: the run may
    continue with another loop than the one that made its steps."""
    result, error, loaded = None, None, None
    if comm.rank == 0:
        try:
            scene, checkpoint = _plan(Path(out), list(overrides), marker, comm.size, large,
                                      any_loop)
            loaded = scene  # written below, once the loop is ready
            source = checkpoint[1].get("source", scene.source) if checkpoint else scene.source
            result = (scene.data(), source, checkpoint)
        except ResumeError as err:
            error = err
        except OSError as err:
            error = ResumeError(f"cannot resume {out}: {err.strerror or err}")
    result, error = comm.bcast((result, error), root=0)
    if error:
        raise error
    from rodfem.scene import validate
    from rodfem.solver.compiled import KernelUnavailable, ready

    data, source, checkpoint = result
    scene = validate(data, source)
    try:
        ready(scene, comm)
    except KernelUnavailable as err:
        raise Unrunnable(f"rodfem: error: {err}; nothing was changed. Repair the cause (the C "
                         "compiler, the cache directory), or resume with RODFEM_KERNEL=0 and "
                         "--any-loop to continue with the PETSc loop, whose last digits "
                         "differ") from None
    if overrides:
        error = None
        if comm.rank == 0:
            try:
                _write_scene(Path(out), loaded)
            except ResumeError as err:
                error = err
        error = comm.bcast(error, root=0)
        if error:
            raise error
    return scene, checkpoint


def _write_scene(out: Path, scene) -> None:
    """The extended run's scene.toml, whole or not at all."""
    from rodfem.output.atomic import io_line, replacing

    try:
        with replacing(out / "scene.toml") as file:
            file.write(scene.to_toml())
    except OSError as err:
        raise WriteError(f"{io_line(err)}; nothing was changed in {out}, and once there is "
                         "room the same command continues it") from None
