"""``plot``: every figure of one run, or of several runs compared.

For one run DIR the figures go to DIR/figures/ (or ``out``):

    contact.png        u(1, t) with the gap g, u(0.5, t), u_t(1, t), σ(1, t); contact shaded
    energy.png         ln(Ê + 0.01) against t (the paper's Figure 5 for its experiments 1, 2)
    spacetime_<field>.png  each saved field over (t, x): u, theta, sigma (and velocity,
                       heat_flux where the scene saves them)
    rod.gif            the rod against the obstacle, coloured by θ (where u and θ are saved)

For several runs contact.png and energy.png overlay them all, and the per-run figures carry the
run's directory name: spacetime_u_<name>.png, ..., rod_<name>.gif, all in one directory (``out``,
by default the first run's figures/). :class:`~rodfem.post.options.Options` chooses the figures,
the time window, the labels, the colouring and the format: the still figures are PNG, PDF or SVG
(``--format``, else the first run's ``output.figure_format``; :mod:`rodfem.output.figures`).

Everything is read and checked before anything is drawn; each figure is one task
(:class:`rodfem.post.tasks.Task`), drawn here or by worker processes (:mod:`rodfem.post.pool`).
"""

from __future__ import annotations

from pathlib import Path

from rodfem.output import figures as formats
from rodfem.post.options import EVERYTHING, KINDS, Options, check
from rodfem.post.runs import (
    PlotError,
    Run,
    RunDirectoryError,
    fields_in_window,
    file_suffixes,
    legend_labels,
    load_run,
)
from rodfem.post.spacetime import MAPS
from rodfem.post.tasks import Task, draw
from rodfem.scene.expressions import shorten

# A label's characters at most, as drawn: a legend's column or a figure's title holds about as
# many, and a label of thousands would overflow the text's raster.
LABEL_WIDTH = 60


def _labels(runs: list[Run], options: Options) -> tuple[list[str], list[str]]:
    """The runs' labels in mathtext (legends) and in plain text (titles of per-run figures):
    the user's, drawn as written (a "$" is a dollar sign) and cut to ``LABEL_WIDTH``, or made of
    names and values."""
    if options.labels is not None:
        plain = [shorten(label, LABEL_WIDTH) for label in options.labels]
        return [label.replace("$", r"\$") for label in plain], plain
    return legend_labels(runs), [legend_labels([run], math=False)[0] for run in runs]


def plan(runs: list[Run], out: Path, options: Options = EVERYTHING) -> list[Task]:
    """The figures of ``runs`` in ``out`` that ``options`` asks for, in the order of the module's
    table; a per-run figure whose data the run did not save is left out."""
    math, plain = _labels(runs, options)
    shared = dict(window=options.window, colour_by=options.colour_by)
    fmt = formats.chosen(options.format, runs[0].scene)
    tasks = [Task(kind, tuple(runs), tuple(math), out / f"{kind}.{fmt}", **shared)
             for kind in ("contact", "energy") if options.draws(kind)]
    for run, label, suffix in zip(runs, plain, file_suffixes(runs), strict=True):
        saved = fields_in_window(run.fields, options.window).t.size > 0
        for name in MAPS:
            if saved and getattr(run.fields, name) is not None \
                    and options.draws(f"spacetime_{name}"):
                tasks.append(Task("spacetime", (run,), (label,),
                                  out / f"spacetime_{name}{suffix}.{fmt}", field=name, **shared))
        if saved and run.fields.u is not None and run.fields.theta is not None \
                and options.draws("rod"):
            tasks.append(Task("rod", (run,), (label,), out / f"rod{suffix}.gif", **shared))
    return tasks


def prepare(dirs: list[Path], out: Path | None = None, options: Options = EVERYTHING,
            force: bool = False) -> list[Task]:
    """Read and check the runs and the options, refuse to replace figures in ``out`` without
    ``force``, create the figure directory, and return the figures to draw.

    Raises:
        RunDirectoryError: a directory is not a rodfem run directory.
        PlotError: an option does not fit the runs, there is nothing to draw, or ``out`` holds
            a file of the same name as a figure (without ``force``). Nothing is written.
    """
    if not dirs:
        raise RunDirectoryError("no run directory given")
    runs = [load_run(Path(d)) for d in dirs]
    check(options, runs)
    given = out is not None
    out = Path(out) if given else runs[0].path / "figures"
    tasks = plan(runs, out, options)
    if not tasks:
        chosen = ", ".join(sorted(options.only, key=KINDS.index))
        why = [" (--no-animation)" if not options.animation and "rod" in options.only else "",
               "" if options.window is None else " in the window (no saved fields there)"]
        raise PlotError(f"nothing to draw: no figure of {chosen} for these runs{''.join(why)}")
    # The default figures/ of one run belongs to it (drawn again from its files at will); an
    # --out directory may hold what the user keeps, and so may the first run's figures/ when
    # several runs are overlaid there.
    existing = [task.path for task in tasks if task.path.exists()]
    if (given or len(runs) > 1) and existing and not force:
        more = f" (and {len(existing) - 1} more)" if len(existing) > 1 else ""
        raise PlotError(f"{existing[0]} exists{more}: --force replaces the figures rodfem "
                        "draws there")
    if any(task.path.is_dir() for task in tasks):
        raise PlotError(f"{next(t.path for t in tasks if t.path.is_dir())} is a directory")
    out.mkdir(parents=True, exist_ok=True)  # an OSError is a write error (exit code 4)
    return tasks


def plot(dirs: list[Path], out: Path | None = None, options: Options = EVERYTHING,
         force: bool = False, workers: int | None = None) -> list[Path]:
    """Draw the figures of one or more run directories.

    Args:
        dirs: run directories written by ``rodfem run``; all are read and checked first.
        out: the figure directory, created if need be (default: the first run's figures/,
            whose figures are replaced; in ``out`` only with ``force``).
        options: which figures, over which time window, with which labels and colours.
        force: replace figures of the same names in ``out`` (no other file is touched).
        workers: processes that draw besides this one; None for one per other CPU when there
            are enough figures to repay their start (about a second each).

    Returns:
        The files written, in the order of the module's table.

    Raises:
        RunDirectoryError, PlotError: as :func:`prepare` (nothing is written).
    """
    from rodfem.post.pool import Drawer, cpus

    tasks = prepare(dirs, out, options, force)
    if workers is None:
        workers = cpus() - 1 if len(tasks) >= 8 else 0
    if workers <= 0:
        return [draw(task) for task in tasks]
    with Drawer(workers) as drawer:
        futures = drawer.submit(tasks)
        drawer.work()
        return [future.result() for future in futures]
