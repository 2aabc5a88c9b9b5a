"""``plot``: every figure of one run, or of several runs compared.

For one run DIR the figures go to DIR/figures/ (or ``out``):

    contact.png        u(1, t) with the gap g, u(0.5, t), u_t(1, t), σ(1, t); contact shaded
    energy.png         ln(Ê + 0.01) against t (the paper's Figure 5)
    spacetime_<field>.png  each saved field over (t, x): u, theta, sigma (and velocity,
                       heat_flux where the scene saves them)
    rod.gif            the rod against the obstacle, coloured by θ (where u and θ are saved)

For several runs contact.png and energy.png overlay them all, and the per-run figures carry the
run's directory name: spacetime_u_<name>.png, ..., rod_<name>.gif, all in one directory (``out``,
by default the first run's figures/).
"""

from __future__ import annotations

from pathlib import Path

from rodfem.post import backend
from rodfem.post.animation import rod_animation
from rodfem.post.curves import contact_figure, energy_figure
from rodfem.post.runs import RunDirectoryError, file_suffixes, legend_labels, load_run
from rodfem.post.spacetime import MAPS, spacetime_figure


def plot(dirs: list[Path], out: Path | None = None) -> list[Path]:
    """Draw the figures of one or more run directories.

    Args:
        dirs: run directories written by ``rodfem run``; all are read and checked first.
        out: the figure directory, created if need be (default: the first run's figures/).

    Returns:
        The files written, in the order above.

    Raises:
        RunDirectoryError: a directory is not a rodfem run directory (nothing is written).
        PlotError: the figure directory cannot be created.
    """
    if not dirs:
        raise RunDirectoryError("no run directory given")
    runs = [load_run(Path(d)) for d in dirs]
    out = Path(out) if out is not None else runs[0].path / "figures"
    out.mkdir(parents=True, exist_ok=True)  # an OSError is a write error (exit code 4)

    backend.off_screen()
    labels = legend_labels(runs)
    written = [contact_figure(runs, labels, out / "contact.png"),
               energy_figure(runs, labels, out / "energy.png")]
    for run, suffix in zip(runs, file_suffixes(runs), strict=True):
        label = legend_labels([run], math=False)[0]
        for name in MAPS:
            if getattr(run.fields, name) is not None:
                written.append(spacetime_figure(run.fields, name, label,
                                                out / f"spacetime_{name}{suffix}.png"))
        if run.fields.u is not None and run.fields.theta is not None:
            written.append(rod_animation(run, label, out / f"rod{suffix}.gif"))
    return written
