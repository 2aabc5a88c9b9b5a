"""The sparse path of the spectra (rodfem.solver.rightmost) against dense QZ
(rodfem.solver.spectrum): the same verdicts, the same eigenvalues in the right half-plane and the
same growth rate to round-off by both error bounds, the count of the right half-plane equal to
QZ's, on the barber scene's three states, the hot rod's Hopf pair, the rigid obstacle held, a
consistent mass and b = 0 (infinite eigenvalues)."""

import numpy as np
import pytest

import rodfem.scene
from rodfem.model import steady
from rodfem.solver import banded
from rodfem.solver.spectrum import Spectra, balanced, eigenvalues, pencil

HOPF = ["model.theta_A=10", "initial.theta0=10", "obstacle.temperature=0",
        "heat_exchange.k1=1000", "heat_exchange.exponent=2", "obstacle.gap=0.11",
        "obstacle.epsilon=0.1", "model.zeta=0.01"]
SCENES = {"barber": [], "hopf": HOPF, "rigid": ["obstacle.kind=rigid", "heat_exchange.k1=60"],
          "consistent": ["discretisation.mass=consistent"], "quasi-static": ["model.b=0"]}
DENSE, SPARSE = Spectra(dense_cells=None), Spectra(dense_cells=0)


def states(name, cells):
    scene = rodfem.scene.load("barber", [*SCENES[name], f"mesh.cells={cells}"])
    problem = steady.of_scene(scene)
    return scene, [problem.linearise(state) for state in problem.states()]


def test_the_sparse_pencil_is_the_dense_one_reordered():
    scene, lins = states("rigid", 20)
    ops, dense = SPARSE.sparse_operators(scene), DENSE.operators(scene)
    for lin in lins:
        A, B = banded.pencil(ops, 0.017, 1.0, 0.5, lin)
        Ad, Bd = pencil(dense, 0.017, 1.0, 0.5, lin)
        n = ops.size
        kept = np.setdiff1d(np.arange(3 * n), [2 * n - 1, 3 * n - 1] if lin.held else [])
        index = np.searchsorted(kept, banded.order(n, lin.held))  # the dense pencil's rows
        assert banded.bandwidths(A, B) <= (5, 5)
        assert np.array_equal(A.toarray(), Ad[np.ix_(index, index)])
        assert np.array_equal(B.toarray(), Bd[np.ix_(index, index)])


def agree(name, cells):
    scene, lins = states(name, cells)
    for lin in lins:
        dense, sparse = DENSE.verdict(scene, lin), SPARSE.verdict(scene, lin)
        assert sparse.verdict == dense.verdict != "unresolved"
        bound = dense.error + sparse.error
        assert abs(sparse.growth_rate - dense.growth_rate) <= bound
        # to 1e-10 where both bounds say round-off allows it (a real eigenvalue's condition
        # number grows with the mesh: 94.27 carries 9e-5 at 500 cells)
        scale = max(1.0, abs(dense.growth_rate))
        assert abs(sparse.growth_rate - dense.growth_rate) <= max(1e-10 * scale, bound)
        found = SPARSE.rightmost(scene, lin, 6)
        every = eigenvalues(*balanced(*DENSE.pencil(scene, lin)))
        right = every[every.real >= 0]
        assert found.right == right.size  # the argument principle's count
        mine = found.values[found.values.real >= 0]
        assert mine.size == right.size
        for lam, err in zip(found.values, found.errors, strict=True):
            # every eigenvalue found is one of the pencil's, within its bound
            assert np.min(np.abs(every - lam)) <= max(err, 1e-10 * abs(lam))
        # the rightmost found is QZ's rightmost, to 1e-10 (below it, members of the cluster
        # at −1/ζ may come in another order: the module's doc)
        top = DENSE.rightmost(scene, lin, 2).values
        assert np.min(np.abs(top - found.values[0])) <= 1e-10 * abs(found.values[0])


@pytest.mark.parametrize("name", [
    "hopf", *(pytest.param(name, marks=pytest.mark.slow)
              for name in ("rigid", "barber", "consistent", "quasi-static"))])
def test_sparse_verdicts_equal_dense_ones_at_100_cells(name):
    agree(name, 100)


@pytest.mark.slow
@pytest.mark.parametrize("cells", [200, 500, 1000])
@pytest.mark.parametrize("name", ["barber", "hopf", "rigid"])
def test_sparse_verdicts_equal_dense_ones_on_finer_meshes(name, cells):
    agree(name, cells)


def test_the_hopf_pair_is_found_and_counted():
    scene, lins = states("hopf", 80)
    found = SPARSE.rightmost(scene, lins[0], 2)
    assert found.right == 2
    assert np.allclose(found.values, [0.1288 + 5.901j, 0.1288 - 5.901j], atol=5e-4)
