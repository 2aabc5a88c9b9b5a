"""The fields a run records, as affine maps of its state s = [Θ; D; U] (node order), and their
values at points of the rod.

θ, σ and the heat flux q are the forms' expressions (:func:`forms.copetti.temperature`,
:func:`~forms.copetti.stress`, :func:`~forms.copetti.heat_flux`) of the P1 functions Θ, U and
U − D, where D/Δt is the velocity (the paper's δⁿ = (Uⁿ − Uⁿ⁻¹)/Δt, Crank–Nicolson's Vⁿ). Each is
affine in s, so :class:`Pointwise` reads its coefficients off the expressions once per run, by
interpolating them into P1 and DG0 for a few probing states, and a field is then a few NumPy
operations on s:

* at the nodes: θ = Θ + θ₀, u = U, the velocity D/Δt;
* per cell: σ = S s + σ₀ and q = Q s + q₀, S and Q sparse (a row per cell, its two nodes in each
  part of s).

:meth:`Pointwise.reading` gives the value of a field at a point x as an affine functional of s,
which the time loops evaluate at every step (:class:`rodfem.output.history.History`).

The coefficients are the same for every scene of a discretisation's structure and constants: a
serial run finds them in the operator cache (:meth:`Discretisation.arrays`) and reads nothing off
the expressions (:class:`Probe`, the only part that needs dolfinx).
"""

from __future__ import annotations

import numpy as np

from rodfem.discrete.cache import conforms
from rodfem.discrete.discretisation import Discretisation

NODE_FIELDS = ("theta", "u", "velocity")
CELL_FIELDS = ("sigma", "heat_flux")
PARTS = ("Θ", "D", "U")  # the parts of the state, in order
D_COLUMNS = (2, 3)  # a CellMap's columns of D: its two nodes, after Θ's


class Pointwise:
    """The recorded fields of a discretisation's scene as affine maps of the state (collective:
    every rank calls the constructor, and every rank holds the maps)."""

    def __init__(self, disc: Discretisation):
        self.comm, self.nodes = disc.comm, disc.nodes
        self.n = disc.nodes.size
        self.x = disc.nodes.x.copy()
        self.dt = disc.scene["time.dt"]
        maps = disc.arrays("pointwise", lambda: Probe(disc).maps(), self._valid)
        self.theta0 = maps["theta0"]
        self.cell0 = {name: maps[f"{name}0"] for name in CELL_FIELDS}
        self.cell_maps = {name: CellMap(maps[f"{name}_values"], maps[f"{name}_columns"])
                          for name in CELL_FIELDS}

    def _valid(self, maps: dict[str, np.ndarray]) -> bool:
        """Whether ``maps`` are of the kinds and shapes :meth:`Probe.maps` makes, every column
        in the state."""
        n = self.n
        layout = {"theta0": ("f8", (n,))}
        for name in CELL_FIELDS:
            layout |= {f"{name}0": ("f8", (n - 1,)), f"{name}_values": ("f8", (n - 1, 6)),
                       f"{name}_columns": ("int", (n - 1, 6))}
        return conforms(maps, layout) and all(
            np.all((0 <= maps[f"{name}_columns"]) & (maps[f"{name}_columns"] < 3 * n))
            for name in CELL_FIELDS)

    def field(self, name: str, s: np.ndarray, dt: float | None = None) -> np.ndarray:
        """The field ``name`` (of :data:`NODE_FIELDS` or :data:`CELL_FIELDS`) of the state s,
        whose D = Uⁿ − Uⁿ⁻¹ is over a step of length ``dt`` (None: the scene's ``time.dt``; an
        adaptive run's steps vary, and D/Δt is the velocity and enters σ through ζ u_xt)."""
        n = self.n
        if name == "theta":
            return s[:n] + self.theta0
        if name == "u":
            return s[2 * n:].copy()
        if name == "velocity":
            return s[n:2 * n] / (self.dt if dt is None else dt)
        scale = None if dt is None or dt == self.dt else self.dt / dt
        values = self.cell_maps[name].apply(s, scale)
        values += self.cell0[name]
        return values

    def reading(self, name: str, x: float) -> tuple[dict[int, float], float]:
        """The field ``name`` at the point x as an affine functional of the state: its weights
        (position in s → weight) and constant. A node field is interpolated; a cell field is its
        cell's value, at a node between two cells their mean (a point within
        :attr:`~rodfem.discrete.nodes.NodeOrder.SNAP` of a cell from a node is the node)."""
        n = self.n
        if name in NODE_FIELDS:
            nodes, weights = self.nodes.interpolation(x)
            offset = {"theta": 0, "velocity": n, "u": 2 * n}[name]
            scale = 1.0 / self.dt if name == "velocity" else 1.0
            terms = {offset + int(i): float(w) * scale for i, w in zip(nodes, weights)}
            constant = (sum(float(w) * self.theta0[int(i)] for i, w in zip(nodes, weights))
                        if name == "theta" else 0.0)
            return terms, constant
        nodes, _ = self.nodes.interpolation(x)
        if len(nodes) == 2:  # inside cell j
            cells = [int(nodes[0])]
        else:  # at node i: the cells on either side of it that there are
            i = int(nodes[0])
            cells = [c for c in (i - 1, i) if 0 <= c <= n - 2]
        terms: dict[int, float] = {}
        constant = 0.0
        A = self.cell_maps[name]
        for cell in cells:
            w = 1.0 / len(cells)
            for i, a in zip(A.columns[cell], A.values[cell]):
                terms[int(i)] = terms.get(int(i), 0.0) + w * float(a)
            constant += w * float(self.cell0[name][cell])
        return {i: w for i, w in terms.items() if w != 0.0}, constant


class CellMap:
    """A cell field's linear part: per cell, the weights of the six entries of the state it reads
    (its two nodes in each part Θ, D, U, in that order), an (n − 1) × 6 table with their
    positions in the state."""

    def __init__(self, values: np.ndarray, columns: np.ndarray):
        self.values, self.columns = values, columns

    def apply(self, s: np.ndarray, d_scale: float | None = None) -> np.ndarray:
        """The field's linear part at the state s: the products summed from 0 in the table's
        order, as a sparse CSR product does; ``d_scale`` multiplies the weights of D (a step of
        another length than the one the weights were read at: they go as 1/Δt)."""
        total = np.zeros(self.values.shape[0])
        for k in range(self.values.shape[1]):
            weights = self.values[:, k]
            if d_scale is not None and k in D_COLUMNS:
                weights = weights * d_scale
            total += weights * s[self.columns[:, k]]
        return total


class Probe:
    """The forms' expressions of θ and of the cell fields, interpolated at probing states: the
    coefficients of :class:`Pointwise` (dolfinx; collective)."""

    def __init__(self, disc: Discretisation):
        from dolfinx import fem

        import forms.copetti as copetti
        from rodfem.discrete import compat

        self.disc, self.comm, self.nodes, self.n = disc, disc.comm, disc.nodes, disc.nodes.size
        self._petsc_vector = compat.petsc_vector
        self.functions = [disc.function(name) for name in PARTS]
        Θ, D, U = self.functions
        c = disc.const
        θ = copetti.temperature(Θ, disc.lifting)
        cell = {"sigma": copetti.stress(U, U - D, θ, c.dt, c.zeta, c.a),
                "heat_flux": copetti.heat_flux(θ)}
        self.theta = disc.function("theta")
        self.theta_expr = fem.Expression(θ, compat.interpolation_points(disc.V))
        self.cell_functions = {name: fem.Function(disc.W) for name in cell}
        self.cell_exprs = {name: fem.Expression(e, compat.interpolation_points(disc.W))
                           for name, e in cell.items()}
        self._owned_nodes = disc.V.dofmap.index_map.size_local
        self._owned_cells = disc.W.dofmap.index_map.size_local
        midpoints = disc.W.tabulate_dof_coordinates()[: self._owned_cells, 0]
        gathered = self.comm.allgather((self.nodes.owned, midpoints))
        self._node_positions = np.concatenate([g[0] for g in gathered])
        self._cell_order = np.argsort(np.concatenate([g[1] for g in gathered]), kind="stable")

    def evaluate(self, parts: list[np.ndarray]) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """θ at the nodes and the cell fields per cell (in order of x) of the state whose parts
        Θ, D, U are the node-ordered arrays ``parts``, by interpolating the forms' expressions
        (collective)."""
        for f, values in zip(self.functions, parts, strict=True):
            self._petsc_vector(f).array[:] = values[self.nodes.owned]
            f.x.scatter_forward()
        self.theta.interpolate(self.theta_expr)
        θ = np.empty(self.n)
        θ[self._node_positions] = np.concatenate(
            self.comm.allgather(self.theta.x.array[: self._owned_nodes].copy()))
        cells = {}
        for name, f in self.cell_functions.items():
            f.interpolate(self.cell_exprs[name])
            owned = np.concatenate(self.comm.allgather(f.x.array[: self._owned_cells].copy()))
            cells[name] = owned[self._cell_order]
        return θ, cells

    def maps(self) -> dict[str, np.ndarray]:
        """The coefficients of θ and the cell fields, read off their expressions: with θ_A = θ_O
        = 0 they are linear in (Θ, D, U), so setting one part to 1 on every third node (no cell sees
        two of them) gives, cell by cell, the coefficient of its left or right node; θ₀, σ₀ and
        q₀ are the fields of s = 0 with the scene's θ_A and θ_O. Each cell field's linear part is a table
        of a row per cell: the weights of its two nodes in each part (:class:`CellMap`)."""
        n = self.n
        zero = [np.zeros(n) for _ in PARTS]
        theta0, cell0 = self.evaluate(zero)
        lifted = (self.disc.const.theta_A, self.disc.const.theta_O)  # L = 0 while they are 0
        kept = [float(constant.value) for constant in lifted]
        for constant in lifted:
            constant.value = 0.0
        coefficients = {name: [] for name in CELL_FIELDS}  # per part: (left, right)
        try:
            for part in range(len(PARTS)):
                left = {name: np.zeros(n - 1) for name in CELL_FIELDS}
                right = {name: np.zeros(n - 1) for name in CELL_FIELDS}
                unit = np.zeros(n)
                for k in range(3):
                    probe = (np.arange(n) % 3 == k).astype(float)
                    parts = [probe if p == part else zero[p] for p in range(len(PARTS))]
                    θ, cells = self.evaluate(parts)
                    unit += θ
                    for name, values in cells.items():
                        left[name][probe[:-1] == 1.0] = values[probe[:-1] == 1.0]
                        right[name][probe[1:] == 1.0] = values[probe[1:] == 1.0]
                for name in CELL_FIELDS:
                    coefficients[name].append((left[name], right[name]))
                expected = np.ones(n) if PARTS[part] == "Θ" else np.zeros(n)
                if not np.array_equal(unit, expected):
                    raise RuntimeError("θ is not Θ plus a function of x: the maps do not apply")
        finally:
            for constant, value in zip(lifted, kept, strict=True):
                constant.value = value
        cells = np.arange(n - 1)
        maps = {"theta0": theta0}
        for name in CELL_FIELDS:
            maps[f"{name}0"] = cell0[name]
            maps[f"{name}_values"] = np.stack(
                [side for left, right in coefficients[name] for side in (left, right)], axis=1)
            maps[f"{name}_columns"] = np.stack(
                [part * n + cells + side for part in range(len(PARTS)) for side in (0, 1)],
                axis=1)
        return maps
