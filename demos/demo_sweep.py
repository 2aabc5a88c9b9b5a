# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: light
# ---

# # rodfem from Python: one run, its data, and a sweep
#
# Run it with `python3 demos/demo_sweep.py`, or `mpirun -n 2 python3 demos/demo_sweep.py`: the
# single runs then share the mesh between the ranks, and the sweep deals its scenes to them.
#
# ## One run
#
# `rodfem.simulate` takes a scene (a built-in name, a TOML path, or a dict shaped like the
# file) and overrides by key. Mistakes raise `rodfem.SceneError` with the line `rodfem run`
# would print.

# +
import numpy as np
from mpi4py import MPI

import rodfem

COMM = MPI.COMM_WORLD


def say(*args) -> None:
    if COMM.rank == 0:
        print(*args, flush=True)


r = rodfem.simulate("paper1", {"time.end": 2, "model.k": 10})
say(f"{r.status}: {len(r.history)} rows, u(1, 2) = {r.history['u_1'][-1]:.6f}")
say("history columns:", ", ".join(r.history.dtype.names))

try:
    rodfem.simulate("paper1", {"model.kk": 10})
except rodfem.SceneError as err:
    say("refused:", err)
# -

# ## Its fields
#
# `r.fields` holds θ (the physical temperature: θ(0, t) = θ_A, the rod's clamped end), u and σ at
# every saved step, with their coordinates: `t`, the nodes `x`, and the cells' midpoints
# `x_cells` for σ, which is constant per cell. They are the arrays that `fields.xdmf` holds for
# a run written to a directory (`out=`). Under mpirun rank 0 holds them.

# +
if COMM.rank == 0:
    f = r.fields
    assert np.all(f.theta[:, 0] == r.scene["model.theta_A"])
    say(f"{f.t.size} saves of {f.x.size} nodes; θ(0, t) = {f.theta[0, 0]:g} at every save; "
        f"max |σ| = {np.abs(f.sigma).max():.4f}")
# -

# Each run has its measures, the numbers a sweep tabulates (`rodfem.output.measures`):

say({name: round(value, 6) for name, value in r.measures.items() if name != "loop_seconds"})

# ## A sweep
#
# A sweep is a base scene, values every scene shares, and the keys to vary: here a 4 × 3 grid
# of the heat exchange k and the viscosity ζ. `rodfem.sweep` takes the dict (or a sweep file's
# path) and returns the table; the scenes share their set-up, so each costs its time loop and one
# factorisation. With `out=` it writes the directory `rodfem sweep` writes.

# +
sweep = {
    "scene": "paper1",
    "set": {"time.end": 2, "solver.method": "direct"},
    "grid": {"model.k": {"logspace": [0.1, 100, 4]}, "model.zeta": [0.2, 0.5, 1.0]},
}
table = rodfem.sweep(sweep, histories=True)
say(f"{len(table)} scenes, {sum(table['status'] == 'complete')} complete")
for i in range(len(table)):
    say(f"  k = {table['model.k'][i]:7.3g}, ζ = {table['model.zeta'][i]:.1f}: contact "
        f"{100 * table['contact_fraction'][i]:5.1f} % of the time in "
        f"{table['contact_intervals'][i]} intervals, max penetration "
        f"{table['max_penetration'][i]:.4f}")
# -

# The row of a scene is its single run's: scene 7 (k = 10, ζ = 0.5) run alone gives the same
# u(1, T) bit for bit, and its history is kept.

alone = rodfem.simulate("paper1", {"time.end": 2, "solver.method": "direct",
                                   "model.k": table["model.k"][7],
                                   "model.zeta": table["model.zeta"][7]}, comm=MPI.COMM_SELF)
assert table["u_1_final"][7] == alone.history["u_1"][-1]
assert np.array_equal(table.history(7), alone.history)
say("scene 7 alone: the same u(1, T) =", alone.history["u_1"][-1])
