# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: light
# ---

# # Calibration and sensitivity: ζ and ε from a noisy measurement, then what the contact depends on
#
# Run it with `mpirun -n 2 python3 demos/demo_calibration.py` (or without `mpirun`); it writes
# into `results/demo_calibration`. With `CI` set in the environment it draws fewer samples for the
# sensitivity indices.
#
# A measurement of the rod of the paper's first experiment gives, at 150 times, the displacement
# of its end u(1, t) and the force p(t) = −σ(1, t) the obstacle exerts on it, each with its own
# noise. Two questions, each one command of rodfem:
#
# 1. Which viscosity ζ and obstacle compliance ε explain the measurement, and how well does it
#    determine them? `rodfem fit` answers with their values, standard errors and correlation.
# 2. Over the ranges of ζ and ε, which of them decides how hard the rod presses on the obstacle
#    and for how long? `rodfem sensitivity` answers with their Sobol indices.
#
# Here the "measurement" is synthetic: a run at known values, ζ = 0.4 and ε = 0.004, with
# Gaussian noise added, so that we can see the fit recover them.

# +
import os
from pathlib import Path

import numpy as np
from mpi4py import MPI

import rodfem

COMM = MPI.COMM_WORLD
SHORT = bool(os.environ.get("CI"))
OUT = Path("results/demo_calibration")
TRUTH = {"model.zeta": 0.4, "obstacle.epsilon": 0.004}
NOISE = {"u_1": 0.002, "contact_force": 0.1}


def say(*args) -> None:
    if COMM.rank == 0:
        print(*args, flush=True)


if COMM.rank == 0:
    OUT.mkdir(parents=True, exist_ok=True)
COMM.barrier()
# -

# ## The scene and the measurement
#
# The scene is the paper's first experiment on 50 cells with Δt = 5·10⁻⁴ up to t = 1.5, solved
# by the `direct` method; it records the contact force beside the default columns
# (`output.history`), since the measurement has it. The measurement is the run at the true
# values, interpolated at 150 times t_i = 0.01 i, with independent noise of standard deviation
# σ_u = 0.002 on u(1) and σ_p = 0.1 on p. The noise comes from a seeded generator: every rank
# draws the same numbers, and rank 0 writes the file.

# +
SCENE = OUT / "rod.toml"
if COMM.rank == 0:
    SCENE.write_text('''scene = "paper1"
description = "the paper's first experiment, coarser, with its contact force recorded"

[mesh]
cells = 50

[time]
end = 1.5
dt = 0.0005

[solver]
method = "direct"

[output]
history = ["contact_force"]
''')
COMM.barrier()

truth = rodfem.simulate(SCENE, TRUTH)
times = np.linspace(0.0, 1.5, 151)[1:]
noise = np.random.default_rng(2024)
measured = {"t": times}
for column, sigma in NOISE.items():
    exact = np.interp(times, truth.history["t"], truth.history[column])
    measured[column] = exact + noise.normal(0.0, sigma, times.size)
DATA = OUT / "measured.csv"
if COMM.rank == 0:
    np.savetxt(DATA, np.column_stack(list(measured.values())), delimiter=",",
               header=",".join(measured), comments="", fmt="%.10g")
COMM.barrier()
say(f"{times.size} times of {', '.join(NOISE)} -> {DATA}")
# -

# ## The fit
#
# A fit file names the scene, the data, each column's weight and the parameters' ranges. Each
# range spans a decade or more, so the fit works in log₁₀ ζ and log₁₀ ε, starting at the middle
# of each range (ζ = 0.316, ε = 0.01). It minimises the weighted sum of squares
#
# $$ S(ζ, ε) = \sum_c \sum_i w_c^2 \big(y_c(t_i; ζ, ε) − d_{c,i}\big)^2, $$
#
# where y_c is the run's column c interpolated at the data's times and d_{c,i} the data. With
# w_c = 1/σ_c each residual is a number of standard deviations, so the two columns weigh alike
# and, at the optimum, S/(m − n) ≈ 1 for m data and n parameters if the model explains the data
# to their noise. The optimiser is SciPy's bounded trust-region least squares; each Jacobian is
# n + 1 runs (the point and a forward difference in each parameter), one small sweep whose runs
# the MPI ranks share. At the optimum, the covariance of the parameters is
# s² (JᵀJ)⁻¹ with s² = S/(m − n): their standard errors and correlation.

# +
FIT = OUT / "fit.toml"
if COMM.rank == 0:
    FIT.write_text(f'''scene = "rod.toml"
data = "{DATA.name}"

[weights]
u_1 = {1 / NOISE["u_1"]:g}
contact_force = {1 / NOISE["contact_force"]:g}

[parameters]
"model.zeta" = [0.1, 1.0]
"obstacle.epsilon" = [1e-3, 1e-1]
''')
COMM.barrier()

fit = rodfem.fit(FIT, out=OUT / "fit", force=True)
say(fit)
# -

# The recovered values against the true ones, in standard errors; and what the residual says of
# the noise. The two parameters' correlation says how far the data tell them apart: a run with a
# larger ζ and a softer obstacle can look alike.

# +
for key, true in TRUTH.items():
    value, stderr = fit.parameters[key]
    say(f"{key} = {value:.6g} ± {stderr:.2g} (true {true:g}: "
        f"{abs(value - true) / stderr:.2f} standard errors, {abs(value / true - 1):.2%} off)")
m, n = sum(fit.numbers["counts"].values()), len(TRUTH)  # the values measured, by column
say(f"|r| / sqrt(m - n) = {fit.residual_norm / np.sqrt(m - n):.3f} "
    f"(m = {m} residuals, n = {n} parameters; 1 if they are the noise)")
say(f"correlation of ζ and ε: {fit.correlation[0, 1]:+.3f}; "
    f"{fit.numbers['runs']} runs, {fit.iterations} iterations")
# -

# `rodfem fit` drew the data against the fitted run, column by column, into `fit/fit.png`; the
# fitted run itself is a run directory, `fit/fitted`, which `rodfem plot` draws as any other.

# ## What the contact depends on: Sobol indices
#
# The second question asks about the measures of the contact over the ranges of ζ and ε, here
# ζ ∈ [0.2, 1] and ε ∈ [10⁻³, 10⁻²]. A sensitivity file declares them as a scene declares its
# measures: the peak contact stress max_t p(t), and the time in contact (the time the end is past
# the obstacle's face). For a measure Y and a parameter X_i (on its scale: log₁₀ ε),
#
# $$ S_i = \frac{\operatorname{Var}\big(E[Y \mid X_i]\big)}{\operatorname{Var} Y}, \qquad
#    S_{T,i} = \frac{E\big[\operatorname{Var}(Y \mid X_{\sim i})\big]}{\operatorname{Var} Y}: $$
#
# the first-order index S_i is the share of Y's variance X_i explains alone, the total index
# S_T,i the share it has a part in, its interactions with the others included. Saltelli's design
# estimates both from N (d + 2) runs for d parameters (N = 256 here; 128 with `CI` set), a sweep
# the MPI ranks share; SALib's bootstrap gives each index a 95 % confidence interval.

# +
SENSITIVITY = OUT / "sensitivity.toml"
if COMM.rank == 0:
    SENSITIVITY.write_text(f'''scene = "rod.toml"
samples = {128 if SHORT else 256}
seed = 1
outputs = ["peak_stress", "contact_time"]

[parameters]
"model.zeta" = [0.2, 1.0]
"obstacle.epsilon" = [1e-3, 1e-2]

[measures]
peak_stress = {{ column = "contact_force", reduce = "max" }}
contact_time = {{ column = "penetration", reduce = "time_positive" }}
''')
COMM.barrier()

indices = rodfem.sensitivity(SENSITIVITY, out=OUT / "sensitivity", force=True)
if COMM.rank == 0:
    print(indices.to_pandas().round(3).to_string())
# -

# The two measures answer differently. The peak stress depends on both: ε takes about two thirds
# of its variance and ζ one third, and each S_i is close to its S_T,i, so they act nearly
# additively (the S_i sum to about 1). The time in contact is ζ's alone: its total index is
# about 1, ε's within its interval of 0. Over these ranges, a stiffer or softer obstacle changes
# how hard the rod presses, hardly how long; the viscosity changes both.
#
# `rodfem sensitivity` drew the indices with their intervals into `sensitivity/sensitivity.png`,
# and kept every run: `sensitivity/samples.csv` has the sampled values, one row per run, and
# `sensitivity/runs/results.csv` their measures, as a sweep's table.
