"""The paper's Section 6, reproduced: five runs, their figures, and an index.md that sets each
figure beside what the paper says about it and what the run measured.

The runs take a second or two; the figures most of the time. They are drawn by worker processes
(:mod:`rodfem.post.pool`), one per CPU but this process's, each run's as soon as it is done,
while the next experiment runs; then by this process too."""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

import dolfinx
import numpy as np
from mpi4py import MPI

import rodfem
import rodfem.scene
from rodfem.model.steady import stationary
from rodfem.output.directories import finish, prepare_directory
from rodfem.output.files import write_text
from rodfem.output.readers import history_path, read_history
from rodfem.run import simulate
from rodfem.studies.common import plural


@dataclasses.dataclass(frozen=True)
class Experiment:
    scene: str
    figure: str  # the paper's figure number, or "—"
    says: str  # what the paper says (Section 6)


EXPERIMENTS = (
    Experiment("paper1", "1", "When ζ = 0.2, initially, the solution is oscillatory with intervals "
               "of contact with penetration (u(1) > g) and separation. […] we observe contact at "
               "later times. The rough behaviour of u_t is due to the fact that the obstacle is "
               "almost rigid."),
    Experiment("paper2", "2", "[…] then we increased the coefficient of viscosity to ζ = 1. […] In "
               "both experiments, we observe contact at later times. […] When ζ = 1, a rapid "
               "stabilization is observed."),
    Experiment("paper3", "3", "Again, during some time, we saw intervals of penetration and "
               "separation but the system evolved towards a state with no contact with the "
               "obstacle with the stress at the contact point equal to zero."),
    Experiment("paper4", "—", "(As experiment 3, with ζ = 1; the paper shows no figure.)"),
    Experiment("paper5", "4", "[…] when the obstacle is more elastic with ε = 1, k = 1 and "
               "ζ = 0.2. As expected, the solution is oscillatory and smoother. At first, it is "
               "seen a large penetration in the obstacle with the oscillations damping out as time "
               "progresses."),
)
FIGURE5 = ("The decay of the energy when ε = 0.01 and k = 1 is shown in Figure 5 where "
           "ln(Ê^n + 0.01) is plotted against time.")
CAPTIONS = {"contact": "u(1, t), u(0.5, t), u_t(1, t) and σ(1, t)", "energy": "ln(Ê + 0.01)",
            "rod": "the rod against the obstacle"}


def caption(path: Path) -> str:
    """What a figure of ``rodfem plot`` shows, from its name (contact.png, spacetime_u.png...)."""
    from rodfem.post.spacetime import MAPS

    kind = path.stem
    if kind.startswith("spacetime_"):
        return MAPS[kind.removeprefix("spacetime_")][1]
    return CAPTIONS[kind]


def measured(scene: rodfem.scene.Scene, run: Path, result) -> str:
    """One paragraph of what the run shows, set against the stationary state."""
    history = read_history(history_path(run))
    t, u_1, sigma_1 = (history[name] for name in ("t", "u_1", "sigma_1"))
    gap, epsilon = scene["obstacle.gap"], scene["obstacle.epsilon"]
    touching = u_1 > gap
    starts = np.flatnonzero(np.diff(touching.astype(int)) == 1) + 1
    contact = (f"{plural(starts.size, 'interval')} of contact (u(1) > g), the first from t = "
               f"{t[starts[0]]:.3f}" if starts.size else "no contact")
    u_star, sigma_star = stationary(np.array([1.0]), scene["model.a"], scene["model.theta_A"],
                                    scene["model.k"], epsilon, gap)
    s = result.summary
    change = s["energy_max_increase"]
    change = f"largest step change {change:.2e}" if change is not None else "fewer than 2 steps"
    ended = ""
    if result.status != "complete":
        ended = f"**The run {result.status} at step {s['steps'] + 1}: {s.get('error', '')}** "
    return (
        f"{ended}{contact}; at t = {t[-1]:g} the rod is "
        f"{'in contact' if touching[-1] else 'free'}, "
        f"u(1) = {u_1[-1]:.5f}, σ(1) = {sigma_1[-1]:.5f}, against the stationary state "
        f"u*(1) = {u_star[0]:.5f}, σ* = {sigma_star:.5f} (`rodfem.model.steady`). Energy "
        f"non-increasing: {'yes' if s['energy_non_increasing'] else 'NO'} ({change}); "
        f"{s['iterations_mean']:.2f} Picard iterations per step."
    )


def _simulate(name: str, out: Path, overrides, force: bool, comm: MPI.Comm, progress: bool):
    """Run a built-in scene into ``out``: the scene, the :class:`~rodfem.run.RunResult`, and
    on rank 0 what the run shows ("" where it is not to be drawn: interrupted, or a file that
    could not be written)."""
    scene = rodfem.scene.load(name, list(overrides))
    prepare_directory(out, force, comm)
    result = simulate(scene, out, comm, progress=progress)
    facts = ""
    if comm.rank == 0 and _drawable(result):
        facts = measured(scene, out, result)
    return scene, result, facts


def _drawable(result) -> bool:
    return result.status != "interrupted" and result.io_error is None


def run_experiment(name: str, out: Path, overrides=(), force: bool = False,
                   comm: MPI.Comm = MPI.COMM_WORLD, progress: bool = True):
    """Run a built-in scene into ``out`` and draw its figures into ``out``/figures.

    Returns the scene, the run's :class:`~rodfem.run.RunResult` and, on rank 0, what the run
    shows (:func:`measured`). An interrupted run is not drawn."""
    from rodfem.post import PlotError, plot  # pyvista only where figures are made

    scene, result, facts = _simulate(name, out, overrides, force, comm, progress)
    if comm.rank == 0 and _drawable(result):
        try:
            plot([out], None, workers=1)
        except PlotError as err:
            facts += f" (No figures: {err}.)"
    comm.barrier()
    return scene, result, facts


def reproduce(out: Path, force: bool = False, comm: MPI.Comm = MPI.COMM_WORLD,
              progress: bool = True, overrides=(), report=lambda line: None,
              format: str | None = None):
    """Run the five experiments into ``out``/paperN, plot them, write ``out``/index.md.

    ``overrides`` (``section.key=value``) apply to every experiment, e.g. a shorter end time;
    ``report`` receives a line as each experiment is done; ``format``: the still figures' (png,
    pdf or svg; default: each scene's ``output.figure_format``, else png). Returns the index, the experiments
    whose run failed, and the run that stopped the reproduction (interrupted, or a file that
    could not be written: its :class:`~rodfem.run.RunResult`) or None."""
    from contextlib import nullcontext

    from rodfem.post.pool import Drawer, cpus

    prepare_directory(out, force, comm, command="paper",
                      files=("index.md", *(e.scene for e in EXPERIMENTS), FIGURE5_DIR))
    with Drawer(cpus() - 1) if comm.rank == 0 else nullcontext() as drawer:
        sections, failed, stopped = _experiments(out, comm, progress, overrides, report, drawer,
                                                 format)
        if stopped is not None:
            if drawer is not None:
                drawer.cancel()
            finish(out, "interrupted" if stopped.io_error is None else "failed", comm)
            return out / "index.md", failed, stopped
        if comm.rank == 0:
            figure5 = _figures(drawer, [out / "paper1", out / "paper2"], out / FIGURE5_DIR,
                               format)
            drawer.work()  # the runs are done: draw here too
            sections = [(*section[:-1], _drawn(section[-1])) for section in sections]
            write_index(out, sections, _drawn(figure5), failed)
    finish(out, "failed" if failed else "complete", comm)
    comm.barrier()
    return out / "index.md", failed, None


FIGURE5_DIR = "figure5"  # Figure 5's directory: the curves of experiments 1 and 2 overlaid


def _figures(drawer, dirs: list[Path], out: Path | None = None, format: str | None = None):
    """Queue the figures of runs (every figure of one run into its figures/, or the curves of
    several overlaid into ``out``), the still ones in ``format`` (None: the run's scene's): the
    figures' futures, or the reason there are none."""
    from rodfem.post import PlotError
    from rodfem.post.options import Options
    from rodfem.post.plot import prepare

    options = Options(format=format) if out is None else \
        Options(only=frozenset({"contact", "energy"}), format=format)
    try:
        return drawer.submit(prepare(dirs, out, options, force=True))
    except PlotError as err:
        return str(err)


def _drawn(figures) -> list[Path] | str:
    """The files of queued figures, once drawn, or the reason there are none."""
    from rodfem.post import PlotError

    if isinstance(figures, str):
        return figures
    try:
        return [future.result() for future in figures]
    except PlotError as err:
        return str(err)


def _experiments(out: Path, comm: MPI.Comm, progress: bool, overrides, report, drawer,
                 format: str | None = None):
    """Run the experiments in turn, each one's figures queued as it is done: the sections of
    the index (experiment, scene, facts, figures), the failed, and the run that stopped them."""
    sections, failed = [], []
    for experiment in EXPERIMENTS:
        run = out / experiment.scene
        scene, result, facts = _simulate(experiment.scene, run, overrides, False, comm, progress)
        if not _drawable(result):
            return sections, failed, result
        if result.status == "failed":
            failed.append(experiment.scene)
        figures = _figures(drawer, [run], None, format) if comm.rank == 0 else []
        sections.append((experiment, scene, facts, figures))
        report(f"{experiment.scene}: {facts}")
    return sections, failed, None


def _links(out: Path, figures: list[Path] | str) -> list[str]:
    """Markdown images of the figures drawn, relative to ``out``, or why there are none."""
    if isinstance(figures, str):
        return [f"(No figures: {figures}.)"]
    return [f"![{caption(path)}]({path.relative_to(out).as_posix()})" for path in figures]


def write_index(out: Path, sections, figure5: list[Path] | str, failed=()) -> None:
    """index.md: per experiment what the paper says, what the run measured and every figure
    drawn; then Figure 5 (experiments 1 and 2 overlaid)."""
    lines = [
        "# Copetti, Section 6, reproduced by rodfem",
        "",
        f"Made by `rodfem paper` on {time.strftime('%Y-%m-%d')} with rodfem {rodfem.__version__}"
        f" and dolfinx {dolfinx.__version__}. Common data, as in the paper: a = 0.017, g = 0.1, "
        "θ_A = 10, h = 1/250, Δt = 0.001, T = 8, θ₀ = θ_A (cos 2πx − sin(πx/2)), u₀ = 0, "
        "u₁ = 20x(x − 1)², lumped mass. Each run's files, and its resolved `scene.toml`, are in "
        "its folder.",
        "",
    ]
    if failed:
        lines += [f"**Not reproduced: the run of {', '.join(failed)} failed** (its section says "
                  "where and why).", ""]
    for experiment, scene, facts, figures in sections:
        e, k, z = scene["obstacle.epsilon"], scene["model.k"], scene["model.zeta"]
        figure = f" (the paper's Figure {experiment.figure})" if experiment.figure != "—" else ""
        lines += [f"## Experiment {experiment.scene[-1]}: ε = {e:g}, k = {k:g}, ζ = {z:g}{figure}",
                  "", f"> {experiment.says}", "", f"rodfem: {facts}", "",
                  *_links(out, figures), ""]
    lines += ["## Figure 5: the energy, ζ = 0.2 against ζ = 1 (ε = 0.01, k = 1)", "",
              f"> {FIGURE5}", "", "Experiments 1 and 2 overlaid:", "", *_links(out, figure5), ""]
    write_text(out / "index.md", "\n".join(lines), MPI.COMM_SELF)
