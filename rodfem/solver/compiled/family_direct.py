"""The direct loop's step family (:mod:`.family`): rk_problem for a step h from the parts.

Once per run: the coupled operator C = [[A_h, −N_U], [−N_Θ, A_m]] as parts in LAPACK's band
storage of the interleaved order (0 where C has no entry); R and b by slots
(:func:`.direct._slots`'s layout) as parts, and the classes of their rows from the parts
stacked; the load e interleaved. For a size h, at λ = Δt₀/h: C's band filled and factored by
``dgbtrf`` (:func:`.direct.band_factors`, as :class:`~.direct.DirectKernel` does), the responses
q = C⁻¹[0; −e] (and q_h = C⁻¹[−e; 0] for a variable exchange) by ``dgbtrs``, the compliance w and
the exchange's scalars read off them as :class:`~rodfem.solver.methods.direct.DirectMethod` does,
the tables of R and b combined: a new ``rk_problem`` whose other fields are the home loop's.
"""

from __future__ import annotations

import numpy as np

from rodfem.solver.compiled.direct import DirectKernel
from rodfem.solver.compiled.family import Bound, StepFamily, heat_first_step, tabled
from rodfem.solver.compiled.laurent import combine

BLOCKS = (((0, 0), "heat.A", 1.0), ((0, 1), "heat.du", -1.0),
          ((1, 0), "momentum.dtheta", -1.0), ((1, 1), "momentum.A", 1.0))
R_BLOCKS = (((0, 0), "heat.theta_prev"), ((1, 0), "momentum.theta_prev"),
            ((1, 1), "momentum.du_prev"), ((1, 2), "momentum.u_prev"))


class FamilyDirect(Bound, DirectKernel):
    """A :class:`~.direct.DirectKernel` of a step h bound to the home method (:mod:`.family`)."""

    what = "compiled direct loop"


def _slot_parts(entries, n: int):
    """R (2n × 3n, block order) by slots, as :func:`.direct._slots` lays it out, from its
    entries (rows, cols, parts 3 × m): slot counts per component, offsets, the parts of its values
    (3 × n × slots) and the largest node distance. Entries whose parts are all 0 are dropped."""
    rows, cols, values = entries
    keep = np.any(values != 0.0, axis=0)
    rows, cols, values = rows[keep], cols[keep], values[:, keep]
    c, i = np.divmod(rows, n)
    k, j = np.divmod(cols, n)
    dj = j - i
    counts, offsets, index = [], [], np.empty(rows.size, dtype=np.int64)
    for part in range(2):
        mine = c == part
        key = k[mine] * (2 * n + 1) + (dj[mine] + n)
        unique, inverse = np.unique(key, return_inverse=True)
        index[mine] = sum(counts) + inverse
        counts.append(unique.size)
        uk, udj = np.divmod(unique, 2 * n + 1)
        offsets.append(3 * (udj - n) + uk)
    dense = np.zeros((3, n, sum(counts)))
    dense[:, i, index] = values
    width = int(np.max(np.abs(dj))) if dj.size else 0
    return counts, np.ascontiguousarray(np.concatenate(offsets), dtype=np.intc), dense, width


def _blocks(parts, blocks, n: int):
    """Entries (rows, cols, parts) of a block matrix of n × n blocks of the parts' operators."""
    rows, cols, values = [], [], []
    for (bi, bj), key, *sign in blocks:
        r, c, v = parts.matrix(key)
        rows.append(bi * n + r)
        cols.append(bj * n + c)
        values.append(v * (sign[0] if sign else 1.0))
    return np.concatenate(rows), np.concatenate(cols), np.concatenate(values, axis=1)


class DirectFamily(StepFamily):
    """The direct loops of any size of one run (the module's docstring)."""

    bound = FamilyDirect

    def __init__(self, home, history, kernel: DirectKernel, parts):
        super().__init__(home, history, kernel, parts)
        n = self.n = kernel.n
        to_interleaved = np.concatenate([2 * np.arange(n), 2 * np.arange(n) + 1])
        self.to_block = np.argsort(to_interleaved)  # interleaved position -> block index
        rows, cols, values = _blocks(parts, BLOCKS, n)
        r, c = to_interleaved[rows], to_interleaved[cols]
        # the band of C's non-zero entries at any size (a = 0: the blocks' own, narrower than
        # the pattern's; the factors are the same, the zeros not eliminated)
        nonzero = np.any(values != 0.0, axis=0)
        r, c, values = r[nonzero], c[nonzero], values[:, nonzero]
        kl, ku = int(max(0, np.max(r - c))), int(max(0, np.max(c - r)))
        self.kl, self.ku, self.ldab = kl, ku, 2 * kl + ku + 1
        self.c_place = (kl + ku + r - c) + self.ldab * c  # in the band, column-major
        self.c_parts = values
        # R and b by slots and classes from the stacked parts (a node's class at every h)
        r_counts, self.r_offset, r_parts, width = _slot_parts(_blocks(parts, R_BLOCKS, n), n)
        if width > kernel._problem.ghost:
            raise ValueError("the parts' R reaches farther than the run's loop")
        self.r_counts = r_counts
        b = np.stack([parts.vector("heat.b"), parts.vector("momentum.b")], axis=2)  # 3 × n × 2
        self.r_class, tables = tabled({"r_value": r_parts, "b": b})
        self.r_value, self.b = tables["r_value"], tables["b"]
        self.e = combine(parts.vector("contact.e"), 1.0)  # a unit force at x = 1
        end = home.massless
        self.end_row = None if end is None else end.step_row[self.to_block]
        self.first_step_operators = heat_first_step(parts, n) if kernel.first_step_special \
            else None
        self.u_1 = 2 * home.last + 1  # ΔU(1) in the interleaved unknowns
        self.F, self.template, self.size = self._problem(home, kernel)
        self.struct_size = kernel._ffi.sizeof("rk_problem")

    def _problem(self, home, kernel):
        """The rk_family of the parts (kept alive here), and the template rk_problem: the home
        loop's, with the classes and slots of R from the parts."""
        ffi = kernel._ffi
        n = self.n
        if np.unique(self.c_place).size != self.c_place.size:
            raise ValueError("two entries of C at one place of its band")
        band = np.zeros((3, self.ldab * 2 * n))  # +0.0 where a part is 0 (of either sign)
        for k in range(3):
            mine = self.c_parts[k] != 0.0
            band[k, self.c_place[mine]] = self.c_parts[k][mine]
        self._kept = kept = {
            "band": band,
            "r_parts": np.ascontiguousarray(self.r_value),
            "b_parts": np.ascontiguousarray(self.b),
            "e": np.ascontiguousarray(self.e),
            "r_class": np.ascontiguousarray(self.r_class, dtype=np.intc),
            "r_offset": self.r_offset,
        }
        F = ffi.new("rk_family *")
        F.n, F.kl, F.ku = n, self.kl, self.ku
        F.r_classes, F.r_width = self.r_value.shape[1], self.r_value.shape[2]
        for field in ("band", "r_parts", "b_parts", "e"):
            setattr(F, field, ffi.cast("double *", ffi.from_buffer(kept[field])))
        if self.end_row is not None:
            kept["end_row"] = np.ascontiguousarray(self.end_row)
            F.end_row = ffi.cast("double *", ffi.from_buffer(kept["end_row"]))
        F.u_1 = self.u_1
        F.exchange = int(kernel._problem.exchange.law != 0)
        F.state = kernel._arrays["s"].size
        kept["work"] = np.zeros(int(kernel._lib.rk_work_size(F)))  # every size's, one at a time
        F.work = ffi.cast("double *", ffi.from_buffer(kept["work"]))
        template = ffi.new("rk_problem *")
        ffi.memmove(template, kernel._problem, ffi.sizeof("rk_problem"))
        template.r_class = ffi.cast("int *", ffi.from_buffer(kept["r_class"]))
        template.r_offset = ffi.cast("int *", ffi.from_buffer(kept["r_offset"]))
        template.r_slots = self.r_counts
        return F, template, int(kernel._lib.rk_form_size(F))

    def _form(self, loop, lam: float) -> None:
        kernel = self.kernel
        ffi = kernel._ffi
        memory = np.empty(self.size)
        P = ffi.new("rk_problem *")
        ffi.memmove(P, self.template, self.struct_size)
        info = kernel._lib.rk_form(self.F, lam, P, ffi.cast("double *", ffi.from_buffer(memory)))
        if info == -1:
            raise RuntimeError("the compliance at x = 1 is not positive")
        if info == -2:
            raise RuntimeError("the end's temperature response to its heat loss is not negative")
        if info:
            raise RuntimeError(f"the coupled operator is singular (dgbtf2 info = {info})")
        loop.band = {"kl": self.kl, "ku": self.ku, "kl_kept": P.kl, "ku_kept": P.ku,
                     "pivoting": bool(P.pivoting)}
        loop.blocked = P.fwd != ffi.NULL
        loop._arrays = {"memory": memory}
        loop.compliance = P.w
        loop._problem = P
        loop._pressure = ffi.new("double *")
