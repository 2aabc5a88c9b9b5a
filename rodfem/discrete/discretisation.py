"""The discrete setting of Section 3: mesh, S_E, measures, and the scheme's operators.

Each residual of ``forms.copetti`` is affine in every function it holds. The operators that the
time loop needs are read off the forms by linearity, once per run:

    F(x; y_1, …, y_m) = A x − Σ_k N_k y_k − b,   A = ∂F/∂x,  N_k = −∂F/∂y_k,  b = −F(0; 0).

So the heat step (3.3) becomes A_h c = N_Θ c^{n−1} + N_U d^{n,l−1} + N_U' d^{n−1} + b_h, which is
the paper's (M + ΔtK + ΔtkB) c^{n,l} = M c^{n−1} + aC(d^{n−1} − d^{n,l−1}) divided by Δt, and the
same for (3.4). Rows and columns of the Dirichlet node x = 0 are removed from every operator
(identity in A, zero in N_k and b), so every vector stays in S_E.

Assembly is distributed; the operators handed to the time loop are sequential copies in node order
(see :mod:`rodfem.discrete.nodes`).

**One set-up for many scenes.** The parameters are :class:`dolfinx.fem.Constant` s of the forms
and the forms' functions are symbols (:meth:`Discretisation.symbol`, zero, one per name), so a
form built again for another scene is the same UFL expression. :meth:`Discretisation.form`
compiles each once (keyed by the expression's ``repr``, which names its functions and constants
by their identity) and :meth:`Discretisation.load` puts another scene's values into the
constants: a sweep over parameters assembles and factors once per scene, and compiles nothing.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import types

from typing import TYPE_CHECKING

import numpy as np

from rodfem.discrete.arrays import Matrix, Vector
from rodfem.discrete.cache import CELLS_MAX, OperatorCache, conforms, digest
from rodfem.discrete.nodes import NodeOrder
from rodfem.scene import Scene
from rodfem.scene.schema import REDISTRIBUTED

if TYPE_CHECKING:
    from mpi4py import MPI
    from petsc4py import PETSc

OBSTACLE = 1  # facet tag of the point x = 1
PARAMETERS = ("a", "b", "zeta", "k", "theta_A")  # the model's, constants of the forms
# What dolfinx makes (:meth:`Discretisation._finite_elements`), on first use.
FINITE_ELEMENTS = ("mesh", "V", "W", "bcs", "ds_1", "dx", "dx_m", "dx_b", "const", "r", "s",
                   "lifting")


@dataclasses.dataclass
class AffineOperator:
    """A x = Σ_k N_k y_k + b for a residual F(x; y) affine in all its functions (node order)."""

    A: PETSc.Mat | Matrix
    N: dict[str, PETSc.Mat | Matrix]
    b: PETSc.Vec | Vector


class Discretisation:
    """P1 on a uniform mesh of I = (0, 1), the space S_E and the measures of the scheme.

    The mesh, spaces, measures and constants (:data:`FINITE_ELEMENTS`) and the nodes are made
    on first use. With ``cache`` (a serial run), the operators, the nodes and the other arrays
    read off the forms (:meth:`arrays`) come from the operator cache where it has them
    (:mod:`rodfem.discrete.cache`): a run that finds them all never imports dolfinx. Call
    :meth:`keep` once they are made, to store them for the next run.

    The operators are sequential PETSc objects, or with ``petsc=False`` on one rank NumPy's
    (:mod:`rodfem.discrete.arrays`: the same arrays, for a run whose steps PETSc never takes,
    which then imports no petsc4py where the cache has them)."""

    def __init__(self, scene: Scene, comm: MPI.Comm | None = None, cache: bool = False,
                 petsc: bool = True):
        if comm is None:
            from mpi4py import MPI

            comm = MPI.COMM_WORLD
        self.scene = scene
        self.comm = comm
        self.petsc = petsc or comm.size > 1
        self.redistributed = scene["discretisation.mass"] in REDISTRIBUTED
        self._symbols: dict[str, object] = {}
        self._forms: dict[str, object] = {}  # by the UFL expression's repr
        self._keyed: dict[tuple, object] = {}  # by a caller's name for it
        self._cache = None
        if (cache and comm.size == 1 and scene["mesh.cells"] <= CELLS_MAX
                and os.environ.get("RODFEM_CACHE", "1") != "0"):
            self._cache = OperatorCache.open(digest(
                {name: scene[name] for name in self.STRUCTURE}, self._constants(scene)))

    @staticmethod
    def _constants(scene: Scene) -> dict[str, float]:
        return {"dt": scene["time.dt"], **{p: scene[f"model.{p}"] for p in PARAMETERS},
                "theta_O": scene["obstacle.temperature"]}

    def __getattr__(self, name: str):
        """The finite element side, made on first use (only for the names it makes)."""
        if name in FINITE_ELEMENTS:
            self._finite_elements()
        elif name == "nodes":
            self.nodes = self._node_order()
        else:
            raise AttributeError(f"'Discretisation' object has no attribute {name!r}")
        return self.__dict__[name]

    def _finite_elements(self) -> None:
        import ufl
        from dolfinx import fem, mesh
        from petsc4py import PETSc

        import forms.copetti as copetti
        from rodfem.discrete import compat

        from rodfem.parallel import real

        scene = self.scene
        # dolfinx needs MPI's communicator (a serial run may hold one without MPI)
        self.mesh = mesh.create_interval(real(self.comm), scene["mesh.cells"], [0.0, 1.0])
        self.V = compat.function_space(self.mesh, "Lagrange", 1)
        self.W = compat.function_space(self.mesh, "DG", 0)  # for the stress σ, constant per cell
        tdim = self.mesh.topology.dim
        self.mesh.topology.create_connectivity(tdim - 1, tdim)

        clamped = mesh.locate_entities_boundary(self.mesh, 0, lambda x: np.isclose(x[0], 0.0))
        dofs = fem.locate_dofs_topological(self.V, 0, clamped)
        self.bcs = [fem.dirichletbc(PETSc.ScalarType(0.0), dofs, self.V)]

        right = mesh.locate_entities_boundary(self.mesh, 0, lambda x: np.isclose(x[0], 1.0))
        tags = mesh.meshtags(self.mesh, 0, right, np.full(right.size, OBSTACLE, dtype=np.int32))
        self.ds_1 = ufl.Measure("ds", domain=self.mesh, subdomain_data=tags)(OBSTACLE)
        self.dx = ufl.dx(domain=self.mesh)
        # The paper's lumped M: 2-point Gauss–Lobatto on each cell is the vertex (trapezoidal)
        # rule, which makes (η_i, η_j) diagonal. Exact quadrature gives the consistent M.
        mass = scene["discretisation.mass"]
        vertices = ufl.dx(domain=self.mesh, scheme="GLL", degree=1)
        # The parameters are constants of the forms, not literals in them: one compiled form
        # serves every value, and no value of a scene is ever written into C code.
        self.const = types.SimpleNamespace(**{
            name: fem.Constant(self.mesh, PETSc.ScalarType(value))
            for name, value in self._constants(scene).items()
        })
        self.dx_m = vertices if mass in ("lumped", "redistributed-lumped") else self.dx
        self.dx_b = self._redistributed(vertices) if self.redistributed else None
        # The temperature's lifting θ = Θ + L, L = −θ_A r + θ_O s (forms.copetti.lifting)
        x = ufl.SpatialCoordinate(self.mesh)
        self.r = copetti.robin_shift(x, self.const.k)
        self.s = copetti.obstacle_shift(x, self.const.k)
        self.lifting = copetti.lifting(self.r, self.s, self.const.theta_A, self.const.theta_O)

    def _node_order(self) -> NodeOrder:
        """The nodes, from the cache where it has them."""
        n = self.scene["mesh.cells"] + 1

        def valid(found: dict[str, np.ndarray]) -> bool:
            every = np.arange(n)
            return (conforms(found, {"x": ("f8", (n,)), "position": ("int", (n,)),
                                     "owned": ("int", (n,))})
                    and np.array_equal(np.sort(found["position"]), every)
                    and np.array_equal(np.sort(found["owned"]), every))

        found = self._cached("nodes", valid)
        if found is not None:
            return NodeOrder(self.comm, found["x"], found["position"], found["owned"])
        nodes = NodeOrder.of_space(self.V)
        if self._cache is not None:
            self._cache.put("nodes", {"x": nodes.x, "position": nodes.position,
                                      "owned": nodes.owned})
        return nodes

    def _cached(self, name: str, valid) -> dict[str, np.ndarray] | None:
        """The arrays the cache has under ``name`` if ``valid`` takes them, else None."""
        found = self._cache.get(name) if self._cache is not None else None
        return found if found is not None and valid(found) else None

    def arrays(self, name: str, make, valid) -> dict[str, np.ndarray]:
        """The arrays ``make()`` returns (a dict of NumPy arrays read off the forms, the same
        for every scene of this discretisation's structure and constants), from the cache where
        it has them under ``name`` and ``valid(arrays)`` takes them (their kinds and shapes are
        those ``make`` gives: :func:`~rodfem.discrete.cache.conforms`); else made and stored."""
        found = self._cached(name, valid)
        if found is None:
            found = make()
            if self._cache is not None:
                self._cache.put(name, found)
        return found

    def keep(self) -> None:
        """Store what was made for the next run (where there is a cache; a failure to write
        costs only that run's start)."""
        if self._cache is not None:
            self._cache.save()

    def library_version(self) -> str:
        """dolfinx's version: the one that made the cached arrays if dolfinx is not loaded."""
        def version() -> str:
            import dolfinx

            return dolfinx.__version__

        return self._version("dolfinx", "dolfinx", version)

    def petsc_version(self) -> str:
        """PETSc's version (major.minor.patch): the one of the run that made the cached arrays
        if petsc4py is not loaded (a new PETSc is a new cache: :mod:`rodfem.discrete.cache`)."""
        def version() -> str:
            from petsc4py import PETSc

            return ".".join(map(str, PETSc.Sys.getVersion()))

        return self._version("petsc", "petsc4py.PETSc", version)

    def _version(self, name: str, module: str, version) -> str:
        """``version()``, or where ``module`` is not loaded the one the cache holds under
        ``name``; kept in the cache where it has none."""
        import sys

        if module not in sys.modules:
            found = self._cached(name, lambda found: conforms(found, {"version": ("str", ())}))
            if found is not None:
                return str(found["version"])
        made = version()
        if self._cache is not None and self._cache.get(name) is None:
            self._cache.put(name, {"version": np.array(made)})
        return made

    def _redistributed(self, vertices) -> tuple:
        """The inertia with the contact node's mass moved to its neighbour (Khenous, Laborde
        & Renard): on the last cell the vertex rule with the density ρ = 2(1 − x)/h, whose
        weights are h at x = 1 − h and 0 at x = 1, so that the node x = 1 has no mass and the
        total mass is kept; elsewhere the base mass, lumped or consistent. (density, measure)
        pairs for ``forms.copetti.inertia``; χ marks the last cell. The dispersion-free mass's
        base is consistent and lumped blended for the ratio Δt/h (a constant of the forms)."""
        import ufl
        from dolfinx import fem
        from petsc4py import PETSc

        h = 1.0 / self.scene["mesh.cells"]
        W = self.W
        χ = fem.Function(W)
        χ.interpolate(lambda x: (x[0] > 1.0 - h).astype(PETSc.ScalarType))  # at its midpoint
        x = ufl.SpatialCoordinate(self.mesh)[0]
        h_cell = ufl.CellVolume(self.mesh)
        last = χ * 2.0 * (1.0 - x) / h_cell
        if self.dx_m is vertices:
            return ((1.0 - χ + last, vertices),)
        if self.scene["discretisation.mass"] == "dispersion-free":
            # β consistent + (1 − β) lumped: P1's frequency is k(1 + (2β − 1)k²h²/24), and the
            # midpoint rule's −k²Δt²/12 cancels it at β = 1/2 + (Δt/h)² (docs/time-schemes.md)
            β = 0.5 + (self.const.dt / h_cell) ** 2
            return ((β * (1.0 - χ), self.dx), ((1.0 - β) * (1.0 - χ) + last, vertices))
        return ((1.0 - χ, self.dx), (last, vertices))

    @contextlib.contextmanager
    def at_step(self, dt: float):
        """Operators made inside are those of a step Δt = ``dt`` (an adaptive run's steps other
        than its first): the forms' constant Δt set to it, the operator cache (which holds the
        scene's Δt) set aside, both put back after."""
        kept = self._cache
        self._cache = None
        self.const.dt.value = dt
        try:
            yield
        finally:
            self.const.dt.value = self.scene["time.dt"]
            self._cache = kept

    STRUCTURE = ("mesh.cells", "discretisation.mass")  # what load() cannot change

    @classmethod
    def key(cls, scene: Scene) -> tuple:
        """What a scene must share with another for :meth:`load` to take it."""
        return tuple(scene[name] for name in cls.STRUCTURE)

    def load(self, scene: Scene) -> None:
        """Take another scene of the same :meth:`key`: its values go into the constants (and
        the cache, which holds one scene's constants, is no longer used)."""
        if self.key(scene) != self.key(self.scene):
            raise ValueError(f"{self.STRUCTURE} differ: {self.key(scene)} != "
                             f"{self.key(self.scene)}")
        self._cache = None
        self.scene = scene
        self.const.dt.value = scene["time.dt"]
        for p in PARAMETERS:
            getattr(self.const, p).value = scene[f"model.{p}"]
        self.const.theta_O.value = scene["obstacle.temperature"]

    def function(self, name: str):
        """A new function of V (for values: a field to save, say)."""
        from dolfinx import fem

        f = fem.Function(self.V)
        f.name = name
        return f

    def symbol(self, name: str):
        """The function of V called ``name`` in forms whose operators are read off by linearity
        (:meth:`affine_operator`): always zero, the same object for every call."""
        if name not in self._symbols:
            self._symbols[name] = self.function(name)
        return self._symbols[name]

    def form(self, a, key: tuple | None = None):
        """``a`` compiled: once per expression (its ``repr``), for every scene :meth:`load`
        takes. ``a`` may be a function that makes the UFL form, and ``key`` a name for it (the
        same key must mean the same form): then it is made only the first time."""
        import ufl
        from dolfinx import fem

        if key is not None and key in self._keyed:
            return self._keyed[key]
        a = a if isinstance(a, ufl.Form) else a()  # (a Form is callable too)
        text = repr(a)
        if text not in self._forms:
            self._forms[text] = fem.form(a)
        if key is not None:
            self._keyed[key] = self._forms[text]
        return self._forms[text]

    def affine_operator(self, F, x: str, y: dict[str, str], loads: tuple[str, ...] = (),
                        key: tuple | None = None):
        """Read A, N_k and b off the residual F(x; y), which must be affine in x and each y_k,
        all of them symbols (:meth:`symbol`) given by name.

        Every function in F must be zero when this is called, so that F itself is F(0; 0) (the
        symbols are). The y_k named in ``loads`` are data on all of I, not functions of S_E (a
        source f, whose value at x = 0 counts): their N_k keep the column of x = 0. ``F`` may be
        a function that makes the residual, and ``key`` its name, as for :meth:`form`: a scene
        that :meth:`load` took then only assembles (and one whose operators are cached, nothing).
        """
        made = []

        def derivative(name: str):
            import ufl

            if not made:
                made.append(F if isinstance(F, ufl.Form) else F())
            return ufl.derivative(made[0], self.symbol(name), ufl.TrialFunction(self.V))

        def residual():
            derivative(x)  # makes it
            return made[0]

        part = (lambda name: None) if key is None else (lambda name: (*key, name))
        A = self.matrix(lambda: derivative(x), diagonal=1.0, key=part("A"))
        N = {name: self.matrix(lambda yk=yk: -derivative(yk), rows_only=name in loads,
                               key=part(name))
             for name, yk in y.items()}
        return AffineOperator(A, N, self.vector(lambda: -residual(), key=part("b")))

    def matrix(self, a, diagonal: float = 0.0, rows_only: bool = False,
               key: tuple | None = None) -> PETSc.Mat | Matrix:
        """The matrix of a bilinear form on S_E (``diagonal`` in the row of x = 0), node order.
        With ``rows_only`` the column of x = 0 is kept and only its row is zero. ``a`` and
        ``key`` as for :meth:`form`; a keyed matrix is cached (:meth:`arrays`). Without a
        cache the assembled matrix is the one returned: its CSR copy would be made the same way
        from the same arrays (where rows are not zeroed, which drops their entries). Without
        PETSc (``petsc=False``), a NumPy matrix of the CSR arrays, assembled or cached."""
        if (key is None or (self._cache is None and not rows_only)) and self.petsc:
            return self._assembled_matrix(a, diagonal, rows_only, key)

        def csr() -> dict[str, np.ndarray]:
            B = self._assembled_matrix(a, diagonal, rows_only, key)
            indptr, indices, values = B.getValuesCSR()
            B.destroy()
            return {"indptr": indptr, "indices": indices, "values": values}

        if key is None or self._cache is None:
            found = csr()
        else:
            found = self.arrays(repr(("matrix", key, diagonal, rows_only)), csr, self._is_csr)
        if not self.petsc:
            return Matrix(found["indptr"], found["indices"], found["values"].copy())
        from petsc4py import PETSc

        size = found["indptr"].size - 1
        B = PETSc.Mat().createAIJ(size=(size, size), comm=PETSc.COMM_SELF, csr=(
            found["indptr"].astype(PETSc.IntType), found["indices"].astype(PETSc.IntType),
            found["values"]))
        B.assemble()
        return B

    def _is_csr(self, found: dict[str, np.ndarray]) -> bool:
        """Whether ``found`` is the CSR form of a matrix on the nodes (what :meth:`matrix`
        stores)."""
        n = self.scene["mesh.cells"] + 1
        if not conforms(found, {"indptr": ("int", (n + 1,)), "indices": ("int", (None,)),
                                "values": ("f8", (None,))}):
            return False
        indptr, indices = found["indptr"], found["indices"]
        return bool(indptr[0] == 0 and np.all(np.diff(indptr) >= 0)
                    and indptr[-1] == indices.size == found["values"].size
                    and np.all((0 <= indices) & (indices < n)))

    def _assembled_matrix(self, a, diagonal: float, rows_only: bool,
                          key: tuple | None) -> PETSc.Mat:
        from petsc4py import PETSc

        from rodfem.discrete import compat

        form = self.form(a, key)
        # The distributed matrix is destroyed once copied: dolfinx 0.5's keeps a reference of
        # its own, which petsc4py never lets go (0.12 MB a 2,000-cell matrix, per scene).
        A = compat.assemble_matrix(form, self.bcs if not rows_only else [],
                                   diagonal if not rows_only else 0.0)
        B = self.nodes.matrix(A)
        A.destroy()
        if rows_only:
            B.zeroRows(np.flatnonzero(self.nodes.x == 0.0).astype(PETSc.IntType), diag=0.0)
        return B

    def vector(self, L, key: tuple | None = None) -> PETSc.Vec | Vector:
        """The vector of a linear form on S_E (0 in the row of x = 0), node order. ``L`` and
        ``key`` as for :meth:`form`; a keyed vector is cached (:meth:`arrays`)."""
        def assembled() -> dict[str, np.ndarray]:
            from rodfem.discrete import compat

            b = compat.assemble_vector(self.form(L, key))
            compat.set_bc(b, self.bcs)
            ordered = self.nodes.vector(b)
            b.destroy()
            return {"values": ordered.array_r.copy()}

        if key is None:
            values = assembled()["values"]
        else:
            n = self.scene["mesh.cells"] + 1
            values = self.arrays(repr(("vector", key)), assembled,
                                 lambda found: conforms(found, {"values": ("f8", (n,))}))["values"]
        if not self.petsc:
            return Vector(np.array(values))
        from petsc4py import PETSc

        return PETSc.Vec().createWithArray(np.array(values), comm=PETSc.COMM_SELF)
