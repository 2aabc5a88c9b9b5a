"""Each ``rodfem`` subcommand's arguments: the makers of its parser (:data:`ADDERS`), from which
:func:`rodfem.cli.parser` builds the command's (and the CLI reference is generated); the options
several subcommands share are :mod:`rodfem.commands.arguments`'."""

from __future__ import annotations

import argparse

from rodfem.commands.arguments import (add_format, add_output, add_overrides, add_progress,
                                       add_yes, path_argument)
from rodfem.scene import BUILTIN, EXTRA


class Defaults(argparse.ArgumentDefaultsHelpFormatter):
    """Each option's help with its default, but where there is none to say (a flag that is off,
    no value, nothing repeated yet) or the help says it already."""

    def _get_help_string(self, action: argparse.Action) -> str:
        if action.default is None or action.default is False or action.default == [] \
                or "(default" in (action.help or ""):
            return action.help or ""
        return super()._get_help_string(action)


def _run(sub) -> None:
    """``rodfem run``: a scene into its directory."""
    run = sub.add_parser(
        "run",
        help="simulate a scene",
        description="Simulate a scene and write history.h5, fields.xdmf, scene.toml and "
        "summary.json into the output directory.",
        formatter_class=Defaults,
    )
    run.add_argument("scene",
                     help=f"a built-in scene ({', '.join(BUILTIN + EXTRA)}) or a TOML file")
    add_output(run, None, "output directory (default: results/<scene name>)",
            "replace an existing run directory")
    add_overrides(run, "override a scene value, e.g. --set model.zeta=1 (repeatable)")
    run.add_argument("--quiet", action="store_true", help="no progress bar and no final line")
    add_progress(run, "draw the progress bar even when output is not a terminal (mpirun)")
    run.add_argument("--no-size-check", dest="large", action="store_true",
                     help="run even if the estimated output or memory exceeds what is free")


def _prepare(sub) -> None:
    """``rodfem prepare``: what a first run would compile, compiled ahead."""
    prepare = sub.add_parser(
        "prepare",
        help="compile the loops, forms and operators of scenes ahead of their first run",
        description="Run each scene named (by default every built-in one) for three steps, "
        "fixed and adaptive, into a temporary directory, so that its compiled loops, forms and "
        "operators are in the per-user caches before its first run ('make setup' does this for "
        "the built-in scenes).",
    )
    prepare.add_argument("scenes", nargs="*", metavar="SCENE",
                         help=f"built-in scenes ({', '.join(BUILTIN + EXTRA)}) or TOML files")
    prepare.add_argument("--quiet", action="store_true", help="no line per scene")


def _sweep(sub) -> None:
    """``rodfem sweep``: the scenes of a sweep file into one table."""
    sweep = sub.add_parser(
        "sweep",
        help="run many scenes of a sweep file, their measures in one table",
        description="Run every scene of a sweep file (a base scene, fixed values, and a grid, "
        "zipped lists or samples of any scene keys) and write results.csv: one row per scene, "
        "its swept values, status and measures. Under mpirun the ranks share the scenes, each "
        "taking the next as it is free; the table is the same for any number of ranks. "
        "'rodfem resume DIR' continues a stopped sweep.",
    )
    sweep.add_argument("file", metavar="SWEEP.toml", help="the sweep file")
    add_output(sweep, None, "output directory (default: results/<sweep file's name>)",
            "replace an existing sweep directory")
    sweep.add_argument("--histories", action="store_true",
                       help="also keep every scene's history, in histories.h5")
    add_yes(sweep)
    sweep.add_argument("--quiet", action="store_true", help="no progress and no final line")
    add_progress(sweep, "a progress line every few seconds even when output is not a terminal")


def _study(sub, name: str, metavar: str, help: str, description: str, progress: str) -> None:
    """A study's command: its file, --out, --force, --quiet and --progress."""
    command = sub.add_parser(name, help=help, description=description)
    command.add_argument("file", metavar=metavar, help=f"the {name} file")
    add_output(command, None, f"output directory (default: results/<{name} file's name>)",
            f"replace an existing {name} directory")
    add_yes(command)
    command.add_argument("--quiet", action="store_true", help="no final line")
    add_progress(command, progress)
    add_format(command, "the base scene's output.figure_format, else png")


def _fit(sub) -> None:
    """``rodfem fit``: a scene's parameters fitted to measured histories."""
    _study(sub, "fit", "FIT.toml", "fit a scene's parameters to measured histories",
           "Fit the parameters of a fit file (a base scene, fixed values, ranges of the "
           "parameters and a CSV of measured histories) by bounded nonlinear least squares, the "
           "runs of each step dealt to the MPI ranks, and write fit.json (the values, their "
           "standard errors and correlations), fitted/ (the run at the optimum) and fit.png. "
           "'rodfem resume DIR' continues a stopped fit.", "a line per batch of runs")


def _sensitivity(sub) -> None:
    """``rodfem sensitivity``: which parameters a scene's measures depend on."""
    _study(sub, "sensitivity", "SENS.toml",
           "Sobol indices (or Morris screening) of a scene's measures over parameter ranges",
           "Draw points over the ranges of a sensitivity file's [parameters] (Saltelli's "
           "sampling, or Morris' trajectories with method = \"morris\"), run them as a sweep "
           "into DIR/runs (under mpirun the ranks share the runs), and write sensitivity.csv: a "
           "row per measure of 'outputs' and parameter, with the first-order and total Sobol "
           "indices S1, ST and their bootstrap confidence intervals (Morris: mu_star, "
           "mu_star_conf, sigma), samples.csv and sensitivity.png. 'rodfem resume DIR' continues "
           "a stopped study to the same indices.",
           "a progress line every few seconds even when output is not a terminal")


def _resume(sub) -> None:
    """``rodfem resume``: a stopped run, sweep, fit or sensitivity study continued."""
    resume = sub.add_parser(
        "resume",
        help="continue a stopped run, sweep, fit or sensitivity study, or extend a finished run",
        description="Continue the run in DIR from its last checkpoint, after Ctrl-C, a signal, "
        "a kill, a full disk or a failure, to the history and fields an uninterrupted run would "
        "have written, bit for bit (under mpirun, on as many ranks as the run had). With --set "
        "time.end=T a finished run goes on to T. A stopped sweep runs the scenes its journal "
        "does not hold (on any number of ranks), to the table an uninterrupted sweep writes; a "
        "stopped fit replays its journal and goes on, to the fit an uninterrupted one finds; a "
        "stopped sensitivity study runs the rest of its runs and analyses them, to the indices "
        "an uninterrupted study writes.",
    )
    resume.add_argument("dir", type=path_argument, metavar="DIR",
                        help="a directory of 'rodfem run', 'rodfem sweep', 'rodfem fit' or "
                        "'rodfem sensitivity'")
    add_overrides(resume, "a later end, time.end=T (the only value a resumed run may change)")
    resume.add_argument("--quiet", action="store_true", help="no progress bar and no final line")
    add_progress(resume, "draw the progress bar even when output is not a terminal (mpirun)")
    resume.add_argument("--no-size-check", dest="large", action="store_true",
                        help="go on even if the estimated output or memory exceeds what is free")
    resume.add_argument("--any-loop", dest="any_loop", action="store_true",
                        help="continue a run even if its steps so far were made by another time "
                        "loop (compiled or PETSc, RODFEM_KERNEL) than this resume would use: "
                        "the history then holds two arithmetics, listed in summary.json's loops")
    add_format(resume, "a fit's or a sensitivity study's base scene's figure format, else png")


def _plot(sub) -> None:
    """``rodfem plot``: the figures of runs or of one sweep."""
    plot = sub.add_parser(
        "plot",
        help="draw the figures of runs",
        description="Draw contact.png, energy.png, spacetime_{u,theta,sigma}.png and rod.gif of "
        "a run directory into DIR/figures. With several directories, contact.png and energy.png "
        "overlay the runs (with a legend below the curves, or coloured by a scene value with "
        "--colour-by) and the per-run figures are named after each run's directory, "
        "e.g. rod_paper2.gif, all in the first directory's figures/ (or FIGDIR). For a sweep "
        "directory, sweep_<measure>.png draws each measure over the swept keys: a line over one, "
        "a coloured map over two grid axes (and lines, one per value of the second), for the "
        "measures that differ between the scenes (--measures chooses); --overlay draws the "
        "scenes' histories kept by 'rodfem sweep --histories' overlaid.",
    )
    plot.add_argument("dirs", nargs="+", type=path_argument, metavar="DIR",
                      help="a run directory written by 'rodfem run', or one sweep directory")
    plot.add_argument("--out", type=path_argument, metavar="FIGDIR",
                      help="figure directory (default: the first DIR's figures/, whose figures "
                      "are drawn again); if FIGDIR holds a figure of a name rodfem would write, "
                      "nothing is drawn, unless --force")
    plot.add_argument("--force", action="store_true",
                      help="replace the figures of the same names in FIGDIR (no other file is "
                      "touched)")
    # the kinds of rodfem.post.options.KINDS, written out: importing rodfem.post loads VTK,
    # which every command would then pay for (and a signal during that import can crash it)
    plot.add_argument("--only", metavar="KINDS",
                      help="draw only these figures, comma-separated: contact, energy, "
                      "spacetime (every saved field's map), spacetime_<field> (theta, u, "
                      "velocity, sigma, heat_flux), rod; for a sweep, its measures (as --measures)")
    plot.add_argument("--no-animation", dest="animation", action="store_false",
                      help="no rod.gif (the slowest figure)")
    plot.add_argument("--window", metavar="T0,T1",
                      help="draw the times T0 <= t <= T1 only (curves, maps and animation; a "
                      "sweep's --overlay)")
    plot.add_argument("--labels", metavar="A,B,...",
                      help="the runs' names in legends and titles, one per DIR, comma-separated "
                      "(default: each directory's name and the values that differ)")
    plot.add_argument("--colour-by", metavar="KEY",
                      help="colour overlaid runs by this scene value (e.g. model.zeta) on a "
                      "sequential colour map, with a colour bar instead of a legend")
    plot.add_argument("--measures", metavar="NAMES",
                      help="a sweep: draw these measures, comma-separated (default: those that "
                      "differ between the scenes, timings and iteration counts left out)")
    add_format(plot, "the first run's or the sweep's base scene's output.figure_format, else "
               "png; rod.gif stays a GIF")
    plot.add_argument("--overlay", action="store_true",
                      help="a sweep: draw its scenes' histories overlaid (sweep_scenes_*.png; "
                      "kept by 'rodfem sweep --histories'), coloured or labelled by the swept "
                      "values; with --measures, their figures too")


def _paper(sub) -> None:
    """``rodfem paper``: the paper's Section 6 reproduced."""
    paper = sub.add_parser(
        "paper",
        help="reproduce the paper's Section 6",
        description="Run the paper's five experiments, draw their figures and Figure 5 "
        "(experiments 1 and 2 overlaid: their energy and their curves), and write index.md, "
        "which sets each figure beside what the paper says about it.",
        formatter_class=Defaults,
    )
    add_output(paper, "results/paper", "output directory", "replace an earlier reproduction")
    add_overrides(paper, "override a value in every experiment, e.g. --set time.end=2")
    add_format(paper, "each scene's output.figure_format, else png; the animations stay GIF")


def _stability(sub) -> None:
    """``rodfem stability``: where each method converges."""
    stability = sub.add_parser(
        "stability",
        help="map where each method converges over (Δt, ε, ζ, a)",
        description="Sweep Δt, ε, ζ and a over a log grid, run the scene at every point with each "
        "method, and write stability.csv (one row per point and method), stability.json (the grid, "
        "the machine, and Picard's measured boundary against the paper's Δt < εζ and the "
        "compliance's w/ε < 1) and figures/stability_<method>.png. Lists are comma-separated. "
        "Points are shared round-robin among MPI ranks.",
        formatter_class=Defaults,
    )
    add_output(stability, "results/stability", "output directory",
            "replace an earlier stability map in --out")
    stability.add_argument("--scene", default="paper1",
                           help=f"the base scene: built-in ({', '.join(BUILTIN)}) or a TOML file")
    add_overrides(stability, "override a base scene value, e.g. solver.max_iterations=500")
    stability.add_argument("--methods", default="direct,newton,picard", help="methods to run")
    from rodfem.studies.verification.stability import (DEFAULT_A, DEFAULT_DT, DEFAULT_EPSILON,
                                                       DEFAULT_ZETA)

    listed = lambda values: ",".join(f"{v:g}" for v in values)  # noqa: E731
    stability.add_argument("--dt", default=listed(DEFAULT_DT),
                           help="time steps, each a divisor of --end")
    stability.add_argument("--epsilon", default=listed(DEFAULT_EPSILON),
                           help="obstacle compliances ε (stiffness 1/ε)")
    stability.add_argument("--zeta", default=listed(DEFAULT_ZETA), help="viscosities ζ")
    stability.add_argument("--a", default=listed(DEFAULT_A), help="thermal couplings a")
    stability.add_argument("--end", default="1", help="end time of every run")
    add_progress(stability, "a line per point even when output is not a terminal (mpirun)")
    add_format(stability, "png")


def _verify(sub) -> None:
    """``verify`` and ``work-precision``: ladders of refinements, with the same options."""
    verify = sub.add_parser(
        "verify",
        help="observed orders of convergence in h and Δt",
        description="Run ladders of refinements in h and in Δt of paper1, paper5 and a scene "
        "without contact (and the manufactured solutions), for every method and time scheme, "
        "against finer reference runs, and a ladder refining h = Δt together of the impact "
        "benchmark against its exact solution, and write orders.csv, orders.md, orders.json, "
        "errors.csv and figures/orders_<scene>.png (log-log, with reference slopes). A scene "
        "file in --scenes gets ladders of its own, with its method and time scheme, and the "
        "orders and Richardson estimates of its measures: measures.csv, measure_orders.csv and "
        "figures/measures_<scene>.png. Ladders are dealt among MPI ranks, the costliest first.",
        formatter_class=Defaults,
    )
    work = sub.add_parser(
        "work-precision",
        help="accuracy against wall time, per method and time scheme",
        description="For each (method, time scheme) run a ladder of (cells, Δt) refinements of "
        "paper1 and paper5, measure the error of u(1, ·) against a fine reference and the wall "
        "time; for each (mass, time scheme, method) a ladder h = Δt of the impact benchmark, "
        "its L1 error of u(1, ·) against the exact solution; and write workprecision.csv, "
        "workprecision.json (with the time at which each choice reaches an error of 1e-3 on "
        "paper5, and the choices the impact rejects) and figures/workprecision_<scene>.png.",
        formatter_class=Defaults,
    )
    for command, default, methods in (
            (verify, "results/verify", "the built-in scenes with the direct method only"),
            (work, "results/work-precision", "the direct method only on paper1 and paper5")):
        add_output(command, default, "output directory",
                "replace an earlier result of this command in --out")
        command.add_argument("--quick", action="store_true",
                             help=f"small ladders, {methods} (seconds)")
        add_progress(command, "a line per ladder even when output is not a terminal")
        add_format(command, "png")
    verify.add_argument("--scenes", help="scenes to verify (default: paper1, paper5, no-contact, "
                        "manufactured and manufactured-gap where rodfem.model.manufactured exists, "
                        "and impact), and scene or sweep files (.toml; a sweep: each of its "
                        "scenes): each refined from its own cells "
                        "and Δt (or tolerance) by 2, 3 rungs with --quick and 4 without, "
                        "against a finer run, with the orders of its measures")
    add_overrides(verify, "override a value of the scene files in --scenes (repeatable)")
    verify.add_argument("--select", metavar="I,J,...",
                        help="verify only these scenes of the sweep files in --scenes: their "
                        "indices in the sweep (results.csv's index, from 0), comma-separated "
                        "(default: every scene)")


def _steady(sub) -> None:
    """``rodfem steady``: every steady state of a scene, its stability, and their branches."""
    steady = sub.add_parser(
        "steady",
        help="every steady state of a scene and its stability",
        description="Find every steady state of a scene (the rod at rest: the temperature "
        "linear, the stress constant, the contact and heat-exchange laws closing one scalar "
        "equation, all of whose roots are found) and its stability (the spectrum of the "
        "dynamic problem linearised about it, discretised like the scene), and write "
        "steady.csv: one row per state, in increasing u(1). With --continue, the states at n "
        "values of a scene value from a to b: branches.csv and figures/branches.png (stable "
        "branches solid, unstable dashed).",
    )
    steady.add_argument("scene",
                        help=f"a built-in scene ({', '.join(BUILTIN + EXTRA)}) or a TOML file")
    add_output(steady, None, "output directory (default: results/<scene name>-steady)",
            "replace an earlier result of this command in --out")
    add_overrides(steady, "override a scene value, e.g. --set heat_exchange.k1=500 (repeatable)")
    steady.add_argument("--continue", dest="continuation", metavar="KEY=a:b[:n]",
                        action="append",
                        help="the branches over the real scene value KEY from a to b, e.g. "
                        "obstacle.temperature=0:30, followed by continuation through their folds "
                        "with their folds, grazing and Hopf points located (points.csv); with "
                        ":n, the states at n values from a to b instead (once; not a time, "
                        "output, solver or initial value, which change no steady state)")
    steady.add_argument("--follow", choices=("fold", "grazing", "hopf"),
                        help="with --continue KEY=a:b and --along: trace the located points of "
                        "this kind over a second scene value (curves.csv, counts.csv, "
                        "figures/curves.png)")
    steady.add_argument("--along", metavar="KEY2=c:d[:n]",
                        help="the second scene value of --follow, at n values from c to d "
                        "(default 41)")
    steady.add_argument("--extrapolate", action="store_true",
                        help="the continuum's growth rates and Hopf points: computed again on "
                        "2 and 4 times the cells and extrapolated in h², each with an error "
                        "estimate")
    add_format(steady, "the scene's output.figure_format, else png")


def _periodic(sub) -> None:
    """``rodfem periodic``: the periodic orbit born where the steady state lost stability."""
    periodic = sub.add_parser(
        "periodic",
        help="the periodic orbit of a scene whose steady state is unstable",
        description="Find the periodic orbit a scene's runs settle on where its steady state "
        "has lost stability at a Hopf bifurcation: a fixed point of N steps of the scene's own "
        "scheme (step T/N, at most time.dt), with u(1) = u* at its start, solved by Newton's "
        "method from a time run settled near it. Writes periodic.csv (the period, the range of "
        "u(1), the fraction of the period in contact, the Floquet multipliers and the orbit's "
        "stability), orbit.csv (one period: t, u(1), theta(1), p, sigma(1)), settled.csv (the "
        "time run's last period) and figures/orbit.png. With --continue, the orbits at n "
        "values of a scene value from a to b, each started from the one before, and "
        "figures/periodic.png (stable solid, unstable dashed).",
    )
    periodic.add_argument("scene",
                          help=f"a built-in scene ({', '.join(BUILTIN + EXTRA)}) or a TOML file")
    add_output(periodic, None, "output directory (default: results/<scene name>-periodic)",
               "replace an earlier result of this command in --out")
    add_overrides(periodic, "override a scene value, e.g. --set model.zeta=0.01 (repeatable)")
    periodic.add_argument("--continue", dest="continuation", metavar="KEY=a:b:n",
                          action="append",
                          help="the orbits over n values of the real scene value KEY from a to "
                          "b, e.g. model.zeta=0.01:0.016:7 (once)")
    add_format(periodic, "the scene's output.figure_format, else png")


# Each subcommand's parser's maker, in the order of the help (``verify`` makes
# ``work-precision`` too).
ADDERS = {"run": _run, "sweep": _sweep, "fit": _fit, "sensitivity": _sensitivity,
          "resume": _resume, "plot": _plot, "paper": _paper, "stability": _stability,
          "verify": _verify, "work-precision": _verify, "steady": _steady, "periodic": _periodic,
          "prepare": _prepare}
