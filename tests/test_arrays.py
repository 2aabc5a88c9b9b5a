"""NumPy's containers (rodfem/discrete/arrays.py) do PETSc's arithmetic bit for bit on the
operators of the built-in scenes (what a run without petsc4py does: tests/test_startup.py)."""

import numpy as np
import pytest
from mpi4py import MPI
from petsc4py import PETSc

from rodfem.discrete.arrays import Matrix, NaturalLU, Vector
from rodfem.discrete.discretisation import Discretisation
from rodfem.scene import load
from rodfem.solver.linalg import lu_factor
from rodfem.solver.methods import make_method

SCENES = {"paper1": ["mesh.cells=60"],
          "impact": ["mesh.cells=60", 'solver.method="direct"'],
          "paper2": ["mesh.cells=60", 'time.scheme="crank-nicolson"']}


def _methods(name):
    scene = load(name, SCENES[name])
    kinds = {}
    for petsc in (True, False):
        kinds[petsc] = make_method(Discretisation(scene, MPI.COMM_SELF, petsc=petsc))
    return kinds[True], kinds[False]


def _petsc(values):
    return PETSc.Vec().createWithArray(np.array(values), comm=PETSc.COMM_SELF)


@pytest.mark.parametrize("name", SCENES)
def test_products_and_lu_are_petscs_bit_for_bit(name):
    with_petsc, with_numpy = _methods(name)
    assert isinstance(with_numpy.R, Matrix) and isinstance(with_numpy.state, Vector)
    rng = np.random.default_rng(7)
    n = with_petsc.disc.nodes.size
    pairs = [(with_petsc.R, with_numpy.R), (with_petsc.coupled_operator(),
                                             with_numpy.coupled_operator())]
    for kind in ("heat", "momentum"):
        pairs.append((getattr(with_petsc, kind).A, getattr(with_numpy, kind).A))
        pairs += [(getattr(with_petsc, kind).N[k], getattr(with_numpy, kind).N[k])
                  for k in getattr(with_petsc, kind).N]
    for A, B in pairs:
        for one, two in zip(A.getValuesCSR(), B.getValuesCSR()):
            assert np.array_equal(one, two)
        rows, cols = A.getSize()
        x, y = rng.standard_normal(cols), rng.standard_normal(rows)
        z_petsc, z_numpy = _petsc(np.zeros(rows)), Vector(np.zeros(rows))
        A.multAdd(_petsc(x), _petsc(y), z_petsc)
        B.multAdd(Vector(x.copy()), Vector(y.copy()), z_numpy)
        assert z_petsc.array_r.tobytes() == z_numpy.array.tobytes()
        A.mult(_petsc(x), z_petsc)
        B.mult(Vector(x.copy()), z_numpy)
        assert z_petsc.array_r.tobytes() == z_numpy.array.tobytes()
    # PETSc's LU in the natural ordering (the paper's first step solves the heat operator)
    for A, B in ((with_petsc.heat.A, with_numpy.heat.A),
                 (with_petsc.momentum.A, with_numpy.momentum.A)):
        b = rng.standard_normal(n)
        x_petsc = _petsc(np.zeros(n))
        lu_factor(A, "test_arrays_")[1].solve(_petsc(b), x_petsc)
        x_numpy = Vector(np.zeros(n))
        NaturalLU(B).solve(Vector(b.copy()), x_numpy)
        assert x_petsc.array_r.tobytes() == x_numpy.array.tobytes()
    # the energy's dot, and the first step and first rows of the run
    s = rng.standard_normal(3 * n)
    assert _petsc(s).dot(_petsc(s[::-1].copy())) == Vector(s).dot(Vector(s[::-1].copy()))
    for method in (with_petsc, with_numpy):
        method.advance()
    assert with_petsc.values.tobytes() == with_numpy.values.tobytes()


# adaptive runs through a contact event: the paper scheme with Picard's loop (its first step
# and Picard's failures made in Python) and Crank–Nicolson with the direct one
ADAPTIVE = {"paper1": ["mesh.cells=60", "time.adaptive=true", "time.end=0.25"],
            "stiff": ["mesh.cells=60", "time.adaptive=true", 'time.scheme="crank-nicolson"',
                      "time.end=0.3"]}


@pytest.mark.parametrize("name", ADAPTIVE)
def test_an_adaptive_run_in_numpys_containers_is_petscs_bit_for_bit(name, monkeypatch):
    """The stepper's own arithmetic on the state (its hand-over, error estimate and first steps)
    gives the same history in NumPy's containers as in PETSc's."""
    import rodfem.run

    scene = load(name, ADAPTIVE[name])
    assert rodfem.run.numpy_run(scene, MPI.COMM_SELF)
    histories = []
    for numpy in (True, False):
        monkeypatch.setattr(rodfem.run, "numpy_run", lambda scene, comm, numpy=numpy: numpy)
        histories.append(rodfem.run.simulate(scene, None, MPI.COMM_SELF, progress=False).history)
    assert histories[0].shape == histories[1].shape and histories[0].shape[0] > 100
    assert histories[0].tobytes() == histories[1].tobytes()
