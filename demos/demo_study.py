# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: light
# ---

# # A study from start to end: peak contact force and time in contact over ζ and ε
#
# Run it with `mpirun -n 2 python3 demos/demo_study.py` (or without `mpirun`); it writes into
# `results/demo_study`. With `CI` set in the environment it uses a shorter time and fewer values.
#
# The question: how hard, and for how long, does the rod of the paper's first experiment press on
# the obstacle, as its viscosity ζ and the obstacle's compliance ε change? A study of it takes
# four steps, each below: state the quantities once, in the scene; check that they have converged
# on this scene; sweep them over ζ × ε; and read the table and the runs as data.

# +
import os
from pathlib import Path

import numpy as np
from mpi4py import MPI

import rodfem
from rodfem.cli import main as rodfem_command

COMM = MPI.COMM_WORLD
SHORT = bool(os.environ.get("CI"))
OUT = Path("results/demo_study")
END = 1.0 if SHORT else 2.0


def say(*args) -> None:
    if COMM.rank == 0:
        print(*args, flush=True)


if COMM.rank == 0:
    OUT.mkdir(parents=True, exist_ok=True)
COMM.barrier()
# -

# ## The scene and its measures
#
# The scene file starts from the paper's experiment (`scene = "paper1"`) and sets only what
# differs. Its `[measures]` table names the quantities of the study, each a column of the run's
# history reduced over the run (or a window of it): the peak of the obstacle's force
# p = −σ(1); the time the end is past the obstacle's face, u(1) − g > 0 (the time in contact,
# each touch's start and end located within its step); the time of the largest |σ(1)|; and the
# mean energy over the run's second half. rodfem records a column a measure names even where
# the scene's output does not, and reduces it over every step as the run goes: the measures do
# not depend on which rows the history keeps.

# +
SCENE = OUT / "rod.toml"
TEXT = f'''scene = "paper1"
description = "the paper's first experiment, its contact measured"

[time]
end = {END}
dt = 0.0002

[solver]
method = "direct"

[measures]
peak_force = {{ column = "contact_force", reduce = "max" }}
contact_time = {{ column = "penetration", reduce = "time_positive" }}
peak_time = {{ column = "sigma_1", reduce = "time_of_max_abs" }}
late_energy = {{ column = "energy", reduce = "mean", window = [{END / 2}, {END}] }}
'''
if COMM.rank == 0:
    SCENE.write_text(TEXT)
COMM.barrier()

run = rodfem.simulate(SCENE)
say(run)
# -

# A result prints as a few lines. Its scene is a read-only mapping of its keys, and its history
# a table (`to_pandas()`, indexed by t): each measure is its column's reduction over every step,
# which NumPy recomputes from the history here.

# +
scene = dict(run.scene)
say(f"{len(scene)} keys; ζ = {scene['model.zeta']}, ε = {scene['obstacle.epsilon']}, "
    f"Δt = {scene['time.dt']}")
history = run.to_pandas()
p = history["contact_force"].to_numpy()
assert run.measures["peak_force"] == p.max()
# the time in contact: on each step, the part where the straight line between its two rows
# of u(1) − g is positive
d, dt = history["penetration"].to_numpy(), np.diff(history.index.to_numpy())
a, b = d[:-1], d[1:]
crossing = (a > 0) != (b > 0)
part = np.where(a > 0, 1.0, 0.0) * np.where(b > 0, 1.0, 0.0)
part[crossing] = np.maximum(a, b)[crossing] / np.abs(b - a)[crossing]
assert np.isclose(run.measures["contact_time"], np.sum(part * dt), rtol=1e-12)
say(f"peak force {run.measures['peak_force']:.4f} = max of the history's column; "
    f"in contact for {run.measures['contact_time']:.4f} of {END:g}")
axes = run.plot(columns=["u_1", "contact_force"])
axes[0].figure.savefig(OUT / "run.png", dpi=110)
# -

# ## Have the measures converged on this scene?
#
# `rodfem verify --scenes rod.toml` refines the scene's own cells and step, each by 2, against
# finer runs, and gives each measure's observed order and the Richardson estimate of the error
# left in the finest run. A measure whose differences do not shrink as they should is marked
# with the reason. (Under mpirun the ranks share the runs.)

# +
rodfem_command(["verify", "--quick", "--scenes", str(SCENE), "--out", str(OUT / "verify"),
                "--force"])
if COMM.rank == 0:
    import pandas as pd

    orders = pd.read_csv(OUT / "verify" / "measure_orders.csv")
    mine = orders[orders["measure"].isin(["peak_force", "contact_time", "late_energy"])]
    print(mine[["refined", "measure", "finest", "order", "richardson", "note"]].fillna("")
          .to_string(index=False))
COMM.barrier()
# -

# ## The sweep: ζ × ε
#
# A sweep file (here a dict of the same shape) names the base scene, the grid and, if it wants,
# more measures. ε is log-spaced: the figures of the sweep draw it on a log axis. The table has a
# column per measure, the declared ones after the built-in ones.

# +
SWEEP = {
    "scene": str(SCENE),
    "grid": {"model.zeta": {"linspace": [0.2, 1.0, 3 if SHORT else 5]},
             "obstacle.epsilon": {"logspace": [1e-4, 1e-2, 3 if SHORT else 5]}},
}
table = rodfem.sweep(SWEEP, out=OUT / "sweep", force=True, histories=True)
say(table)
# -

# As a pandas table, the peak force over the grid, ζ down and ε across:

# +
if COMM.rank == 0:
    frame = table.to_pandas()
    print(frame.pivot(index="model.zeta", columns="obstacle.epsilon",
                      values="peak_force").round(3).to_string())
    print(frame.pivot(index="model.zeta", columns="obstacle.epsilon",
                      values="contact_time").round(4).to_string())
# -

# The sweep's figures: one per measure that differs between the scenes (timings and counts
# left out unless named), axes in the paper's symbols, and with `--overlay` the scenes' histories
# over one another. `--measures` chooses the figures.

# +
rodfem_command(["plot", str(OUT / "sweep"), "--measures", "peak_force,contact_time", "--force"])
rodfem_command(["plot", str(OUT / "sweep"), "--overlay", "--out", str(OUT / "overlay"),
                "--force"])
# -

# ## One run's fields as data
#
# The fields of a run are an xarray Dataset on (t, x), the stress on the cells (t, x_cells):
# here the rod's mean temperature ∫θ dx and the temperature at the obstacle at a few times, as
# xarray reduces and selects them.

# +
if COMM.rank == 0:
    fields = run.fields.to_xarray()
    mean = fields["theta"].integrate("x")
    for time in (0.0, END / 2, END):
        at = fields.sel(t=time, method="nearest")
        print(f"t = {float(at['t']):.2f}: ∫θ dx = {float(mean.sel(t=time, method='nearest')):.4f}, "
              f"θ(1) = {float(at['theta'].sel(x=1.0)):.4f}")
# -
