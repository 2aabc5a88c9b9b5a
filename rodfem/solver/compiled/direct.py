"""The `direct` method's time loop in compiled code: many steps in one C call.

A step of :class:`rodfem.solver.methods.direct.DirectMethod` is linear algebra with constant
operators and one scalar equation (the contact force); in Python each of its PETSc calls costs
about a microsecond, which at a few hundred cells is most of the step. :class:`DirectKernel` reads
the operators off a method and its history once and runs ``steps`` steps in ``direct.c``:

    [h; m] = R s + b                  (s = [Θⁿ⁻¹; Dⁿ⁻¹; Uⁿ⁻¹], R: 2n × 3n, ``method.R``)
    z = C⁻¹ [h; m]                    (C = ``method.coupled_operator()``, 2n × 2n)
    c = Uⁿ⁻¹(1), s₁ = c + z_U(1)
    p = the law's solve of y + w p(y) = s₁ where contact is possible (contact.h), else 0
    [ΔΘⁿ; ΔUⁿ] = z + p q              (q = ``method.response``, w = ``method.compliance``)
    Θⁿ = Θⁿ⁻¹ + ΔΘⁿ, Uⁿ = Uⁿ⁻¹ + ΔUⁿ, Dⁿ = ΔUⁿ (Crank–Nicolson with inertia: 2ΔUⁿ − Dⁿ⁻¹)

with a heat exchange that depends on the contact (``method.exchange_step``) p and the flux φ
from exchange.h's scalar equation and [ΔΘⁿ; ΔUⁿ] = z + p q + φ q_h (q_h =
``method.heat_response``), and for each new state the raw row of
:data:`rodfem.solver.record.RAW` (record.h), which
:meth:`rodfem.output.history.History.take` turns into rows of ``history.h5`` as it does the
PETSc loop's.

A redistributed mass (:mod:`rodfem.solver.methods.massless`) changes only the end x = 1:
without its mass, Dⁿ(1) = Uⁿ(1) − Uⁿ⁻¹(1); eliminated (Crank–Nicolson, ζ = 0), c and s₁ are
its free position y (a row on Θ and U of the nodes n − 2 and n − 1, so the update of the last
node waits for the next one), w and the law are y's (``method.compliance``, the obstacle in
series with the last cell: the linear law, for the linear law and the rigid obstacle; the power
law is refused), and after the update the end is settled (``MasslessEnd.settle``) before the
energy rows that read it, its force the step's p (contact.h's rc_end).

**Node-interleaved order.** Interleaved by node, [Θ₀, D₀, U₀, Θ₁, …] for the state and
[ΔΘ₀, ΔU₀, ΔΘ₁, …] for the unknowns, every operator couples only neighbouring nodes: C is banded
(kl = ku = 3 for P1; 2 kept for a = 0, where C is block diagonal) and a row of R or E reads
nodes i − 1 .. i + 1. C is permuted so and factored once, by LAPACK's dgbtrf; direct.c does
dgbtrs's substitutions, node-blocked where there are no row interchanges, with U's diagonal as
reciprocals. R and E are stored as
dense rows over "slots" (the offsets into the packed state some row uses), and each of
[R | b] and [E | 2w] as a table of its distinct rows with a class number per node
(:func:`rodfem.solver.compiled.loop.classes`): the same numbers, so the same results bit for bit
(``compress=False`` keeps a row per node, for the tests). Why each choice, with the bytes it
saves: docs/performance.md.

**Round-off.** The arithmetic is the PETSc loop's but for the order of summation and the
factorisation (LAPACK's band LU against PETSc's LU in reverse Cuthill–McKee order): over a run the
difference adds up about linearly in the steps, and ``tests/test_kernel.py`` bounds it by 64 eps
per step. A step whose s₁ lies within round-off of g could take the other branch of the contact
test in the two.

**What it does not do.** The paper scheme's first step with inertia (n = 0 → 1,
:meth:`Method._first_step`) is left to ``method.advance()``; sources are refused at
construction. A step whose exchange equation is not shown to have one root stops the loop at the
step before it, with :class:`~rodfem.solver.errors.NoUniqueStep`. The loop is rank-local, as the
state is (every rank holds all of it and computes the same rows).

**Building.** direct.c is compiled with cffi on first use and cached (:mod:`.build`);
:func:`available` says whether it could be built and loaded, checked against its build's record
(else a run that needs it refuses: :func:`rodfem.solver.compiled.compiled_loop`); importing this
module compiles nothing and raises nothing.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from rodfem.solver.compiled.build import CompiledSource
from rodfem.solver.compiled.loop import CompiledLoop, check_library, classes, energy_tables
from rodfem.solver.errors import NoUniqueStep
from rodfem.solver.methods.exchange_step import NOT_UNIQUE

SOURCE = Path(__file__).with_name("direct.c")
KMAX = 8  # the widest band of the blocked substitutions (band.h)

_source = CompiledSource(SOURCE, "_rodfem_kernel_", "kernel", check_library)
_library = _source.library
available = _source.available
unavailable_reason = _source.unavailable_reason


_lapack = []  # scipy's LAPACK, once loaded


def scipy_lapack():
    """SciPy's LAPACK functions (``scipy.linalg.lapack``'s: those of its extension module
    ``scipy.linalg._flapack``), the extension loaded alone where scipy.linalg is not imported yet:
    importing scipy.linalg imports scipy.sparse too, 40 ms of a small run's start, for one
    dgbtrf. The same functions of the same library, so the same factors bit for bit."""
    if not _lapack:
        _lapack.append(_flapack_alone() if "scipy.linalg" not in sys.modules else None)
        if _lapack[0] is None:
            from scipy.linalg import lapack

            _lapack[0] = lapack
    return _lapack[0]


def solve_tridiagonal(ab: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``scipy.linalg.solve_banded((1, 1), ab, b)`` as SciPy computes it (LAPACK's ``dgtsv`` on
    copies of the three diagonals), without importing scipy.linalg (:func:`scipy_lapack`)."""
    *_, x, info = scipy_lapack().dgtsv(np.array(ab[2, :-1], dtype=float),
                                       np.array(ab[1, :], dtype=float),
                                       np.array(ab[0, 1:], dtype=float),
                                       np.array(b, dtype=float))
    if info != 0:
        raise np.linalg.LinAlgError(f"a tridiagonal matrix is singular (dgtsv's info {info})")
    return x


def _flapack_alone():
    """scipy.linalg._flapack loaded from its file without its package, or None."""
    import importlib.machinery
    import importlib.util

    try:
        scipy = importlib.util.find_spec("scipy")  # found, not imported
        directory = Path(scipy.origin).parent / "linalg"
        for suffix in importlib.machinery.EXTENSION_SUFFIXES:
            path = directory / f"_flapack{suffix}"
            if path.is_file():
                spec = importlib.util.spec_from_file_location("scipy.linalg._flapack", path)
                module = importlib.util.module_from_spec(spec)
                spec.loader.exec_module(module)
                return module if hasattr(module, "dgbtrf") else None
    except Exception:  # noqa: BLE001 (any other layout: scipy.linalg's own import)
        return None
    return None


def _csr(A) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(row of each entry, column, value) of a PETSc AIJ matrix."""
    ia, ja, a = A.getValuesCSR()
    rows = np.repeat(np.arange(len(ia) - 1), np.diff(ia))
    return rows, np.asarray(ja, dtype=np.int64), np.asarray(a, dtype=float)


def _slots(A, parts: int, n: int):
    """A (parts·n × 3n, block order) by slots: per component of its rows, the offsets into the
    packed state (3 (j − i) + k for the column k·n + j of row c·n + i) some row uses, in CSR
    column order; their values as an n × (total slots) array; the largest node distance."""
    rows, cols, values = _csr(A)
    keep = values != 0.0
    rows, cols, values = rows[keep], cols[keep], values[keep]
    c, i = np.divmod(rows, n)
    k, j = np.divmod(cols, n)
    dj = j - i
    counts, offsets, index = [], [], np.empty(rows.size, dtype=np.int64)
    for part in range(parts):
        mine = c == part
        # ascending (k, dj) is the CSR's column order within a row
        key = k[mine] * (2 * n + 1) + (dj[mine] + n)
        unique, inverse = np.unique(key, return_inverse=True)
        index[mine] = sum(counts) + inverse
        counts.append(unique.size)
        uk, udj = np.divmod(unique, 2 * n + 1)
        offsets.append(3 * (udj - n) + uk)
    dense = np.zeros((n, sum(counts)))
    dense[i, index] = values
    width = int(np.max(np.abs(dj))) if dj.size else 0
    return counts, np.ascontiguousarray(np.concatenate(offsets), dtype=np.intc), dense, width


def _blocked(lu: np.ndarray, kl: int, ku: int, kl_kept: int, ku_kept: int, n: int):
    """The node-blocked recurrences of band.h (forward_blocked, backward_blocked) from
    dgbtrf's factors without interchanges, P = I: per node i, l_i and F_i (rows 0, 1), and
    d00, d01, d11 and H_i (rows 0, 1)."""
    kd, N = kl + ku, 2 * n

    def entry(rows: np.ndarray, cols: np.ndarray, lower: bool) -> np.ndarray:
        """L(rows, cols) (lower) or U(rows, cols), 0 outside the matrix and the factor."""
        d = rows - cols
        inside = (cols >= 0) & (cols < N) & (rows >= 0) & (rows < N)
        inside &= (d > 0) & (d <= kl) if lower else (d <= 0) & (-d <= kd)
        out = np.zeros(rows.shape)
        out[inside] = lu[kd + d[inside], cols[inside]]
        return out

    i = np.arange(n)
    r0, r1 = 2 * i, 2 * i + 1
    fwd = np.zeros((n, 2 * kl_kept + 1))
    ell = entry(r1, r0, True)
    fwd[:, 0] = ell
    for t in range(kl_kept):
        c = 2 * i - kl_kept + t
        below0 = entry(r0, c, True)
        fwd[:, 1 + t] = below0
        fwd[:, 1 + kl_kept + t] = entry(r1, c, True) - ell * below0
    bwd = np.zeros((n, 2 * ku_kept + 3))
    u00, u01, u11 = entry(r0, r0, False), entry(r0, r1, False), entry(r1, r1, False)
    d00, d11 = 1.0 / u00, 1.0 / u11
    bwd[:, 0], bwd[:, 1], bwd[:, 2] = d00, d00 * u01 * d11, d11
    for t in range(ku_kept):
        c = 2 * i + 2 + t
        above1 = entry(r1, c, False)
        bwd[:, 3 + t] = d00 * (entry(r0, c, False) - u01 * d11 * above1)
        bwd[:, 3 + ku_kept + t] = d11 * above1
    return fwd, bwd


def band_factors(lu: np.ndarray, ipiv: np.ndarray, info: int, kl: int, ku: int, n: int,
                 blocked: bool = True) -> tuple[dict, dict]:
    """The arrays of rk_problem's factors from dgbtrf's (``lu``, ``ipiv``, ``info``) of the
    interleaved coupled operator of band (kl, ku): (the band's sizes, the arrays ``lower``,
    ``upper``, ``rdiag``, ``ipiv``, and ``fwd``, ``bwd`` of the node-blocked substitutions, None
    where there are row interchanges or ``blocked`` is False). RuntimeError if it is singular."""
    if info != 0:
        raise RuntimeError(f"the coupled operator is singular (dgbtrf info = {info})")
    N, kd = 2 * n, kl + ku
    ipiv = np.ascontiguousarray(ipiv, dtype=np.intc)
    pivoting = bool(np.any(ipiv != np.arange(N)))
    lower = lu[kd + 1:kd + 1 + kl, :].T  # lower[j, t] = L(j + 1 + t, j)
    upper = lu[kd - 1::-1, :].T if kd else np.zeros((N, 0))  # upper[j, t] = U(j - 1 - t, j)
    kl_kept = int(np.max(np.nonzero(lower.any(axis=0))[0], initial=-1)) + 1
    ku_kept = int(np.max(np.nonzero(upper.any(axis=0))[0], initial=-1)) + 1
    band = {"kl": kl, "ku": ku, "kl_kept": kl_kept, "ku_kept": ku_kept, "pivoting": pivoting}
    arrays = {
        "lower": np.ascontiguousarray(lower[:, :kl_kept]),
        "upper": np.ascontiguousarray(upper[:, :ku_kept]),
        "rdiag": 1.0 / lu[kd, :],
        "ipiv": ipiv,
        "fwd": None,
        "bwd": None,
    }
    # Without interchanges, the node-blocked substitutions (``blocked=False``: dgbtrs's).
    if blocked and not pivoting and max(kl_kept, ku_kept) <= KMAX:
        # per node: these differ in their last bits from node to node
        arrays["fwd"], arrays["bwd"] = _blocked(lu, kl, ku, kl_kept, ku_kept, n)
    return band, arrays


def _energy(history, n: int, compress: bool) -> tuple:
    """E by slots and [E | 2w] as a table of its distinct rows: (slot counts, offsets, width,
    class of each node, tables)."""
    counts, offsets, values, width = _slots(history.energy.E, 3, n)
    two_w = history.energy.two_w.array_r.reshape(3, n).T
    return (counts, offsets, width, *classes({"e_value": values, "two_w": two_w}, compress))


class DirectKernel(CompiledLoop):
    """Steps of a :class:`~rodfem.solver.methods.direct.DirectMethod` in compiled code (the
    module's docstring).

    ``DirectKernel(method, history)`` reads the operators once; :meth:`advance` then does steps
    exactly as ``method.advance()`` from any n ≥ 1 (n ≥ 0 where the first step is not special:
    Crank–Nicolson, or no inertia), updating the method in place and writing history rows."""

    what = "compiled direct loop"

    def __init__(self, method, history, blocked: bool = True, compress: bool = True):
        lapack = scipy_lapack()
        super().__init__(method, history)
        self._ffi, self._lib = _library()
        n = self.n
        N = 2 * n
        block = np.arange(N)  # interleaved position 2i + c holds block index c n + i
        to_block = (block % 2) * n + block // 2

        # C, interleaved and banded; its band from the pattern; LAPACK's band LU.
        rows, cols, vals = _csr(method.coupled_operator())
        to_interleaved = np.empty(N, dtype=np.int64)
        to_interleaved[to_block] = block
        r, c = to_interleaved[rows], to_interleaved[cols]
        kl, ku = int(max(0, np.max(r - c))), int(max(0, np.max(c - r)))
        kd = kl + ku
        ab = np.zeros((2 * kl + ku + 1, N), order="F")
        ab[kd + r - c, c] = vals
        lu, ipiv, info = lapack.dgbtrf(ab, kl, ku)
        self.band, arrays = band_factors(lu, ipiv, info, kl, ku, n, blocked)
        self.blocked = arrays["fwd"] is not None
        if not self.blocked:
            del arrays["fwd"], arrays["bwd"]
        rows_r = {}
        # R and E by slots, b, q and 2w interleaved.
        r_counts, arrays["r_offset"], rows_r["r_value"], r_width = _slots(method.R, 2, n)
        rows_r["b"] = method.b.array_r[to_block].reshape(n, 2)
        arrays["q"] = np.ascontiguousarray(method.response.array_r[to_block])
        if method.exchange_step is not None:  # and q_h, the response to a heat loss at x = 1
            arrays["qh"] = np.ascontiguousarray(method.heat_response.array_r[to_block])
        # R and b (read by the forward pass), E and 2w (the backward pass): tables of their
        # distinct rows and each node's row in them (the module's docstring).
        arrays["r_class"], tables_r = classes(rows_r, compress)
        e_counts, arrays["e_offset"], e_width, arrays["e_class"], tables_e = energy_tables(
            history, ("direct", compress), lambda: _energy(history, n, compress))
        arrays.update(tables_r)
        arrays.update(tables_e)
        self.compress = compress
        self.classes = {"r": int(tables_r["b"].shape[0]), "e": int(tables_e["two_w"].shape[0])}
        ghost = max(r_width, e_width)
        arrays["s"] = np.zeros(3 * (n + 2 * ghost))
        arrays["z"] = np.zeros(N)
        self._arrays = arrays  # the C struct points into these: keep them

        def pack(index: int) -> int:  # block-order state index -> packed position
            return 3 * (index % n) + index // n

        i, wi, j, wj = history.half
        ffi = self._ffi
        P = ffi.new("rk_problem *")
        P.n, P.ghost = n, ghost
        band = self.band
        P.kl, P.ku, P.pivoting = band["kl_kept"], band["ku_kept"], int(band["pivoting"])
        P.reach = kl if band["pivoting"] else band["kl_kept"]
        for field, array in arrays.items():
            ctype = "int *" if array.dtype == np.intc else "double *"
            assert array.flags.c_contiguous and array.dtype in (np.intc, np.float64)
            setattr(P, field, ffi.cast(ctype, ffi.from_buffer(array)))
        P.r_slots = r_counts
        P.e_slots = e_counts
        P.e_ghost = e_width
        P.w = method.compliance  # an eliminated end's: that of its free position y
        self.set_obstacle(P.obstacle, method)
        self.set_exchange(P.exchange, method)
        self.set_end(P.end, self._lib)
        P.midpoint_inertia = self.velocity_update
        P.u_1, P.du_1 = pack(history.u_1), pack(history.du_1)
        P.half_i, P.half_j, P.half_wi, P.half_wj = pack(i), pack(j), wi, wj
        self.set_record(P, history)
        self._problem = P
        self._pressure = ffi.new("double *")

    @staticmethod
    def set_exchange(target, method) -> None:
        """Fill exchange.h's rx_exchange: the law (RX_CONSTANT: no flux) and the step's scalars
        (:class:`~rodfem.solver.methods.exchange_step.ExchangeStep`)."""
        law, step = method.exchange, method.exchange_step
        target.law = law.code if step is not None else 0
        if step is None:
            return
        target.k1 = law.k1
        target.exponent = getattr(law, "exponent", 1.0)
        target.gap, target.length = getattr(law, "gap", 0.0), getattr(law, "length", 1.0)
        target.alpha, target.beta, target.gamma = step.alpha, step.beta, step.gamma
        target.weight, target.offset = step.weight, step.offset

    def _run(self, steps: int, rows: np.ndarray):
        method = self.method
        self._pressure[0] = method.pressure
        done = self._lib.rk_advance(self._problem, self.pointer(method.values),
                                    self.pointer(method.u_prev.array), method.n, steps,
                                    self.pointer(rows), self._pressure)
        error = None
        if done < steps:
            step = method.n + done + 1
            time = step * method.dt if method.clock is None else method.clock + method.dt
            error = NoUniqueStep("direct", step, time, NOT_UNIQUE)
        return done, float(self._pressure[0]), 1, error
