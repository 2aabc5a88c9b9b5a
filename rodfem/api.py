"""rodfem from Python: run a scene (:func:`simulate`), read a run directory (:func:`load`), and
what both give back (:class:`Result`, :mod:`rodfem.output.result`); a scene's steady states and
their stability (:func:`steady`). The API sits above the studies: it imports them (``steady``),
never the other way round.

    >>> import rodfem
    >>> r = rodfem.simulate("paper1", {"time.end": 1, "model.k": 10})
    >>> r.history["u_1"][-1], r.fields.theta[:, 0]      # θ(0, t) = θ_A at every saved step
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from rodfem.output.columns import for_scene
from rodfem.output.readers import Fields
from rodfem.output.result import Result, load, named_history  # noqa: F401 (rodfem.load, rodfem.Result)
from rodfem.scene import Scene, SceneError, read, validate, with_values
from rodfem.scene import load as load_scene
from rodfem.scene.files import based
from rodfem.scene.values import with_changes


def scene_of(scene: str | Path | Mapping | Scene, overrides=None) -> Scene:
    """The validated scene of a built-in name, a TOML path, TOML-shaped data (a dict of
    sections) or a :class:`Scene`, with ``overrides`` ({"model.k": 10}, or the command line's
    ["model.k=10"]) set.

    Raises:
        SceneError: the message ``rodfem run`` would print, on one line.
    """
    if isinstance(overrides, (list, tuple)):
        if not all(isinstance(item, str) for item in overrides):
            raise SceneError('overrides: a list holds "section.key=value" strings; give a dict '
                             '({"model.k": 10}) for values')
        if not isinstance(scene, (str, Path)):
            raise SceneError("overrides: a list of section.key=value goes with a scene name or "
                             'path; give a dict ({"model.k": 10}) otherwise')
        return load_scene(str(scene), list(overrides))
    if overrides is not None and not isinstance(overrides, Mapping):
        raise SceneError('overrides: must be a dict of scene keys, e.g. {"model.k": 10}, not '
                         f"{type(overrides).__name__}")
    if isinstance(scene, Scene):
        data, source = scene.data(), scene.source
        data["description"] = scene.description
    elif isinstance(scene, Mapping):
        data, source = based(dict(scene), "scene"), "<dict>"  # it may name a base scene
    elif isinstance(scene, (str, Path)):
        data, source = read(scene)
    else:
        raise SceneError("scene: must be a built-in name, a TOML path or a dict of sections, not "
                         f"{type(scene).__name__}")
    values = {key: value.item() if isinstance(value, np.generic) else value  # NumPy scalars
              for key, value in dict(overrides or {}).items()}
    data = with_values(data, values, "overrides")
    if values and isinstance(data.get("description", ""), str):  # as --set: the keys named
        data["description"] = with_changes(data.get("description", ""), values)
    return validate(data, source)


def simulate(scene: str | Path | Mapping | Scene, overrides=None, out: str | Path | None = None,
             comm=None, *, force: bool = False, progress: bool = False) -> Result:
    """Run a scene and return its :class:`Result`.

    Args:
        scene: a built-in name ("paper1"), a TOML path, a dict shaped like the file
            ({"model": {"k": 10}}), or a :class:`Scene`.
        overrides: scene keys to set, {"model.k": 10, "time.end": 2}.
        out: a run directory to write, as ``rodfem run --out`` does (it must not exist, or
            ``force``); None keeps everything in memory, the saved fields included.
        comm: the MPI communicator of the run (default ``MPI.COMM_WORLD``: under ``mpirun``
            the ranks share the mesh).
        progress: draw a progress bar on a terminal.

    A run whose method fails or which a signal stops is returned with ``status`` failed or
    interrupted and the steps it took. A complete fixed-step run that touched the obstacle with
    a step coarse for it warns (:class:`rodfem.CoarseStepWarning`, on rank 0: the line
    ``rodfem run`` prints, with its fix); the result is the same.

    Raises:
        SceneError: a mistake in the scene or the overrides (the CLI's one-line message).
        rodfem.OutputError: ``out`` cannot be used.
    """
    from rodfem.output import interrupts

    with interrupts.call():  # a signal stops this call, not the next
        return _simulate(scene, overrides, out, comm, force, progress)


def _simulate(scene, overrides, out, comm, force: bool, progress: bool) -> Result:
    from mpi4py import MPI

    from rodfem.output.directories import prepare_directory
    from rodfem.run import simulate as run

    comm = comm or MPI.COMM_WORLD
    resolved = scene_of(scene, overrides)
    if resolved.targets:  # an accuracy target: the mesh and steps chosen for it
        return _simulate_to_target(resolved, out, comm, force, progress)
    if out is None:
        done = _in_memory(resolved, run(resolved, None, comm, progress=progress,
                                        keep_fields=True))
    else:
        out = Path(out)
        from rodfem.output.files import write_text

        prepare_directory(out, force, comm)
        write_text(out / "scene.toml", resolved.to_toml(), comm)
        run(resolved, out, comm, progress=progress)
        comm.barrier()
        done = load(out)
    if comm.rank == 0:
        _warn_coarse(done)
    return done


def _in_memory(scene, result) -> Result:
    """The :class:`Result` of a run made without files."""
    fields = None
    if result.fields is not None:
        _, t, values = result.fields
        x = result.x
        fields = Fields(x, t, (x[1:] + x[:-1]) / 2, **values)
    return Result(scene, result.summary, named_history(result.history, for_scene(scene)), fields)


def _simulate_to_target(scene, out, comm, force: bool, progress: bool) -> Result:
    """:func:`simulate` of a scene with an accuracy target (:mod:`rodfem.studies.accuracy`):
    the reported run's result, its ``errors``; a target not met warns
    (:class:`AccuracyWarning`, on rank 0)."""
    from rodfem.output.directories import ACCURACY_FILES, RUN_FILES, finish, prepare_directory
    from rodfem.studies.accuracy.ladder import AccuracyWarning, LadderFailed, not_met_line
    from rodfem.studies.accuracy.run import simulate_to_target

    if out is not None:
        out = Path(out)
        from rodfem.output.files import write_text

        prepare_directory(out, force, comm, files=(*RUN_FILES, *ACCURACY_FILES))
        write_text(out / "scene.toml", scene.to_toml(), comm)
    try:
        chosen, result, record = simulate_to_target(scene, out, comm, progress=progress,
                                                    keep_fields=out is None)
    except LadderFailed as err:  # the failed or stopped run of the ladder, as a run's result
        if out is not None:
            finish(out, err.result.status, comm)
        return _in_memory(err.scene, err.result)
    if out is None:
        done = _in_memory(chosen, result)
    else:
        comm.barrier()
        done = load(out)
    missed = not_met_line(record)
    if missed is not None and comm.rank == 0:
        warnings.warn(missed, AccuracyWarning, stacklevel=4)
    return done



def _warn_coarse(result: Result) -> None:
    """The warning of a complete run whose fixed step is coarse for the contact it had
    (:func:`rodfem.model.timescales.coarse_run`), pointing at the caller of simulate."""
    from rodfem.model.timescales import CoarseStepWarning, coarse_run

    coarse = coarse_run(result.scene, {**result.summary, "status": result.status})
    if coarse is not None:
        warnings.warn(coarse.line, CoarseStepWarning, stacklevel=4)


def steady(scene: str | Path | Mapping | Scene, overrides=None, over=None) -> list[dict]:
    """Every steady state of a scene with its stability, as ``rodfem steady`` writes them.

    Args:
        scene, overrides: as for :func:`simulate`.
        over: (key, values): the states at each value of that real scene key, as
            ``rodfem steady --continue`` writes them, each with its ``parameter`` and ``branch``.

    Returns:
        One dict per state, in increasing u(1) (per value, with ``over``): ``u_1``, ``sigma_1``,
        ``theta_1``, ``contact``, ``stable``, ``growth_rate`` (the largest real part of the
        spectrum of the problem linearised about it), ``h``, ``tangential`` (on a fold),
        ``residual`` (of the steady equation), ``growth_error`` and ``trust``: ``ok``, or why
        ``stable`` is None (``residual``, ``neutral``, ``unresolved``; ``rodfem steady``).

    Raises:
        SceneError: a mistake in the scene, the overrides or a value of ``over``, or a key
            of ``over`` that changes no steady state (time, output, solver, initial values).
    """
    from rodfem.solver.spectrum import Spectra
    from rodfem.studies.steady import states as st

    spectra = Spectra()
    if over is None:
        return st.analyse(scene_of(scene, overrides), spectra)
    key, values = over
    base = scene_of(scene, overrides)
    try:
        st.check_key(key, base)
    except st.SteadyError as err:
        raise SceneError(str(err).removeprefix("--continue: ")) from None
    values = np.asarray(values, dtype=float)
    return st.continuation([scene_of(base, {key: float(v)}) for v in values], values, spectra,
                           key)


def bifurcation(scene: str | Path | Mapping | Scene, key: str, lo: float, hi: float,
                overrides=None, extrapolate: bool = False) -> dict[str, list[dict]]:
    """The branches of steady states of a scene over the real scene value ``key`` from ``lo``
    to ``hi``, followed by continuation, and the points located on them, as ``rodfem steady
    --continue KEY=lo:hi`` writes them.

    Returns:
        ``branches``, the rows of branches.csv (each state with its stability, ``branch`` and
        its ``point`` along it), and ``points``, the rows of points.csv (``kind`` fold, grazing or hopf, the ``parameter``, the state there, and for a
        Hopf point ``omega``, ``period``, the first Lyapunov coefficient ``lyapunov`` with its
        ``lyapunov_error`` and ``criticality``: supercritical, subcritical or degenerate; with
        ``extrapolate`` the continuum's parameter and period with their error estimates).

    Raises:
        SceneError: a mistake in the scene, the overrides or the range, or a key that changes
            no steady state.
    """
    from rodfem.solver.spectrum import Spectra
    from rodfem.studies.steady import diagram
    from rodfem.studies.steady import states as st

    base = scene_of(scene, overrides)
    try:
        st.check_key(key, base)
        st.parse_continuation(f"{key}={float(lo)!r}:{float(hi)!r}", base)
        st.check_mesh(base, 4 if extrapolate else 1)
    except st.SteadyError as err:
        raise SceneError(str(err).removeprefix("--continue: ")) from None
    for value in (lo, hi):
        scene_of(base, {key: float(value)})
    spectra = Spectra()
    found = diagram.compute(base, key, min(lo, hi), max(lo, hi), spectra, extrapolate)
    return {"branches": found.branch_rows, "points": found.point_rows}
