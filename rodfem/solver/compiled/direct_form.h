/*
 * direct_form.h -- the rk_problem of a step size formed from the operators' Laurent parts
 * (rodfem/solver/compiled/family_direct.py): an adaptive run's new step size in microseconds. A
 * part of direct.c, included by it after rk_problem and rk_family: not a header of its own.
 *
 * At lam = dt0/h every coefficient is P0 + P1 lam + P2 lam^2 (laurent.py's combine, the same
 * operations in the same order). The interleaved coupled operator C is put in LAPACK's band
 * storage and factored by dgbtf2's algorithm (the unblocked banded LU with partial pivoting that
 * dgbtrf runs for bands narrower than its block): the same pivots, the multipliers scaled by the
 * pivot's reciprocal, the same rank-one updates; the factors are then laid out as
 * direct.py's band_factors does (kept bands, reciprocal diagonal, and without interchanges the
 * node-blocked recurrences of _blocked, the same expressions), the response q = C^-1 [0; -e]
 * (and q_h = C^-1 [-e; 0]) solved by dgbtrs's algorithm (U's diagonal as its reciprocals, as
 * band.h's substitutions take it), and the compliance read off q. C's parts come in the band
 * storage itself, 0 where C has no entry: (P0 + P1 lam) + P2 lam^2 at every place is combine's
 * sum (a part that is 0 adds an exact 0, whose sign no part that is not 0 sees), in one pass.
 * The common bands (kl = ku = 3, and 2) are constants of their own copy of the code, whose loops
 * the compiler unrolls: the same operations in the same order.
 */
#ifndef RODFEM_DIRECT_FORM_H
#define RODFEM_DIRECT_FORM_H

/* The doubles of rk_form's memory (the ints of ipiv in their own doubles): what a size keeps,
 * the responses and tables first, then rdiag and ipiv, then the factors the steps read: without
 * interchanges the node-blocked recurrences fwd and bwd, else the kept bands lower and upper, in
 * one place (a size has one or the other), each as wide as the kept bands and no wider. The band
 * being factored and a step's work are the family's (rk_work_size). A size's pages are those
 * it writes: q_h's only with a variable exchange, the factors' of its own kept bands (a new
 * size's cost was mostly first touches of fresh pages; the adaptive loop's pool of sizes reuses
 * them). */
static size_t form_layout(const rk_family *F, size_t *at)
{
    const size_t n = F->n, N = 2 * n, kl = F->kl, kd = F->kl + F->ku;
    const size_t blocked = n * (2 * kl + 1) + n * (2 * kd + 3), banded = N * kl + N * kd;
    const size_t sizes[7] = {N, F->exchange ? N : 0, (size_t)F->r_classes * F->r_width,
                             (size_t)F->r_classes * 2, N, (N + 1) / 2,
                             blocked > banded ? blocked : banded};
    size_t total = 0;
    for (int k = 0; k < 7; k++) {
        at[k] = total;
        total += sizes[k];
    }
    return total;
}

long rk_form_size(const rk_family *F)
{
    size_t at[7];
    return (long)form_layout(F, at);
}

/* The family's work: the band storage (2 kl + ku + 1) x 2n, the packed state and z (2n). */
long rk_work_size(const rk_family *F)
{
    return (long)((2 * (size_t)F->kl + F->ku + 1) * 2 * (size_t)F->n + (size_t)F->state
                  + 2 * (size_t)F->n);
}

static inline double form_combine(const double *parts, size_t count, size_t k, double lam)
{
    return parts[k] + parts[count + k] * lam + parts[2 * count + k] * (lam * lam);
}

/* dgbtf2 on ab (ldab x N, column-major, kl subdiagonals, ku superdiagonals, the first kl rows
 * fill-in): ipiv 0-based, and rdiag the reciprocals of U's diagonal (the pivots' reciprocals
 * dgbtf2 scales the multipliers by). Returns 0, or 1 + the first zero pivot's column. */
RK_INLINE int form_factor(double *ab, int N, const int kl, const int ku, int *ipiv,
                           double *rdiag)
{
    const int kv = ku + kl, ldab = 2 * kl + ku + 1;
    int info = 0, ju = 0;
#define AB(i, j) ab[(size_t)(j) * ldab + (i)] /* 0-based row of the band storage */
    for (int j = ku + 1; j < (kv < N ? kv : N); j++)
        for (int i = kv - j; i < kl; i++)
            AB(i, j) = 0.0;
    for (int j = 0; j < N; j++) {
        if (j + kv < N)
            for (int i = 0; i < kl; i++)
                AB(i, j + kv) = 0.0;
        const int km = kl < N - 1 - j ? kl : N - 1 - j;
        int jp = 0;
        double big = fabs(AB(kv, j));
        for (int i = 1; i <= km; i++)
            if (fabs(AB(kv + i, j)) > big) {
                big = fabs(AB(kv + i, j));
                jp = i;
            }
        ipiv[j] = j + jp;
        if (AB(kv + jp, j) != 0.0) {
            const int reach = j + ku + jp < N - 1 ? j + ku + jp : N - 1;
            ju = ju > reach ? ju : reach;
            if (jp != 0)
                for (int c = 0; c <= ju - j; c++) {
                    const double t = AB(kv + jp - c, j + c);
                    AB(kv + jp - c, j + c) = AB(kv - c, j + c);
                    AB(kv - c, j + c) = t;
                }
            const double r = 1.0 / AB(kv, j);
            rdiag[j] = r;
            if (km > 0) {
                for (int i = 1; i <= km; i++)
                    AB(kv + i, j) *= r;
                for (int c = 1; c <= ju - j; c++) {
                    const double t = -AB(kv - c, j + c);
                    if (t != 0.0)
                        for (int i = 1; i <= km; i++)
                            AB(kv + i - c, j + c) += AB(kv + i, j) * t;
                }
            }
        } else {
            rdiag[j] = 1.0 / AB(kv + jp, j);
            if (info == 0)
                info = j + 1;
        }
    }
#undef AB
    return info;
}

/* dgbtrs's solve of x (N) by the factors: the interchanges and L, then U (dtbsv's, with U's
 * diagonal as the reciprocals rdiag, as band.h's substitutions take it). */
RK_INLINE void form_solve(const double *ab, int N, const int kl, const int ku,
                          const int *ipiv, const double *rdiag, double *x)
{
    const int kd = kl + ku, ldab = 2 * kl + ku + 1;
    for (int j = 0; j < N - 1; j++) {
        const int lm = kl < N - 1 - j ? kl : N - 1 - j, l = ipiv[j];
        if (l != j) {
            const double t = x[l];
            x[l] = x[j];
            x[j] = t;
        }
        const double t = -x[j];
        const double *col = ab + (size_t)j * ldab + kd + 1;
        for (int i = 0; i < lm; i++)
            x[j + 1 + i] += col[i] * t;
    }
    for (int j = N - 1; j >= 0; j--) {
        if (x[j] == 0.0)
            continue;
        const double *col = ab + (size_t)j * ldab;
        const double t = x[j] * rdiag[j];
        x[j] = t;
        const int top = j - kd > 0 ? j - kd : 0;
        for (int i = j - 1; i >= top; i--)
            x[i] -= t * col[kd + i - j];
    }
}

/* rk_form with the band kl, ku constants where they are the common ones (rk_form). */
RK_INLINE int form_at(const rk_family *F, double lam, rk_problem *P, double *memory, const int kl,
                      const int ku)
{
    const int n = F->n, N = 2 * n, kd = kl + ku;
    size_t at[7];
    form_layout(F, at);
    double *q = memory + at[0], *qh = memory + at[1], *rv = memory + at[2], *b = memory + at[3];
    double *rdiag = memory + at[4], *factors = memory + at[6];
    int *ipiv = (int *)(memory + at[5]);
    const size_t ldab = 2 * (size_t)kl + ku + 1, band = ldab * N;
    double *ab = F->work, *s = F->work + band, *z = s + F->state;
    /* P0 + P1 lam + P2 lam^2 at each place of the band, 0 where C has no entry: the sums of
     * laurent.py's combine (a part that is 0 adds 0) */
    const double *p0 = F->band, *p1 = p0 + band, *p2 = p1 + band, lam2 = lam * lam;
    for (size_t k = 0; k < band; k++)
        ab[k] = (p0[k] + p1[k] * lam) + p2[k] * lam2;
    const int info = form_factor(ab, N, kl, ku, ipiv, rdiag);
    if (info)
        return info;
    /* the kept bands, the interchanges, the reciprocal diagonal */
    int klk = 0, kuk = 0, pivoting = 0;
    for (int j = 0; j < N; j++) {
        const double *col = ab + (size_t)j * ldab;
        for (int t = klk; t < kl; t++)
            if (col[kd + 1 + t] != 0.0)
                klk = t + 1;
        for (int t = kuk; t < kd; t++)
            if (col[kd - 1 - t] != 0.0)
                kuk = t + 1;
        pivoting |= ipiv[j] != j;
    }
    const int blocked = !pivoting && klk <= KMAX && kuk <= KMAX;
    double *fwd = factors, *bwd = factors + (size_t)n * (2 * klk + 1);
    double *lower = factors, *upper = factors + (size_t)N * klk;
    if (!blocked)
        for (int j = 0; j < N; j++) {
            const double *col = ab + (size_t)j * ldab;
            for (int t = 0; t < klk; t++)
                lower[(size_t)j * klk + t] = col[kd + 1 + t];
            for (int t = 0; t < kuk; t++)
                upper[(size_t)j * kuk + t] = col[kd - 1 - t];
        }
    /* _blocked's recurrences: L(r, c) = ab[c ldab + kd + r - c] for 0 < r - c <= kl, U(r, c)
     * the same for 0 <= c - r <= kd, 0 elsewhere and outside the matrix */
    if (blocked)
        for (int i = 0; i < n; i++) {
            const int r0 = 2 * i, r1 = 2 * i + 1;
            double *f = fwd + (size_t)i * (2 * klk + 1), *g = bwd + (size_t)i * (2 * kuk + 3);
            const double ell = kl >= 1 ? ab[(size_t)r0 * ldab + kd + 1] : 0.0;
            f[0] = ell;
            for (int t = 0; t < klk; t++) {
                const int c = r0 - klk + t;  /* r0 - c = klk - t in 1 .. kl */
                double below0 = 0.0, below1 = 0.0;
                if (c >= 0) {
                    const double *col = ab + (size_t)c * ldab + kd + (r0 - c);
                    below0 = col[0];
                    below1 = r1 - c <= kl ? col[1] : 0.0;
                }
                f[1 + t] = below0;
                f[1 + klk + t] = below1 - ell * below0;
            }
            const double u01 = kd >= 1 ? ab[(size_t)r1 * ldab + kd - 1] : 0.0;
            const double d00 = rdiag[r0], d11 = rdiag[r1];  /* 1/U(r0, r0), 1/U(r1, r1) */
            g[0] = d00;
            g[1] = d00 * u01 * d11;
            g[2] = d11;
            for (int t = 0; t < kuk; t++) {
                const int c = r0 + 2 + t;  /* c - r1 = t + 1 <= kd */
                double above0 = 0.0, above1 = 0.0;
                if (c < N) {
                    const double *col = ab + (size_t)c * ldab + kd;
                    above1 = col[-(t + 1)];
                    above0 = t + 2 <= kd ? col[-(t + 2)] : 0.0;
                }
                g[3 + t] = d00 * (above0 - u01 * d11 * above1);
                g[3 + kuk + t] = d11 * above1;
            }
        }
    /* the responses and the compliance */
    for (int i = 0; i < n; i++) {
        q[2 * i] = 0.0;
        q[2 * i + 1] = -F->e[i];
    }
    form_solve(ab, N, kl, ku, ipiv, rdiag, q);
    double w = -q[F->u_1];
    if (F->end_row) {
        double y = 0.0;
        for (int j = 0; j < N; j++)
            y += F->end_row[j] * q[j];
        w = -y;
    }
    if (!(w > 0.0))
        return -1;
    if (F->exchange) {
        for (int i = 0; i < n; i++) {
            qh[2 * i] = -F->e[i];
            qh[2 * i + 1] = 0.0;
        }
        form_solve(ab, N, kl, ku, ipiv, rdiag, qh);
        const int last = F->u_1 - 1;  /* dTheta(1) */
        if (!(qh[last] < 0.0))
            return -2;
        P->exchange.alpha = qh[F->u_1];
        P->exchange.beta = q[last];
        P->exchange.gamma = qh[last];
    }
    /* the tables of R and b */
    const size_t rcount = (size_t)F->r_classes * F->r_width, bcount = (size_t)F->r_classes * 2;
    for (size_t k = 0; k < rcount; k++)
        rv[k] = form_combine(F->r_parts, rcount, k, lam);
    for (size_t k = 0; k < bcount; k++)
        b[k] = form_combine(F->b_parts, bcount, k, lam);
    for (int k = 0; k < F->state; k++)
        s[k] = 0.0;
    P->kl = klk;
    P->ku = kuk;
    P->pivoting = pivoting;
    P->reach = pivoting ? kl : klk;
    P->lower = lower;
    P->upper = upper;
    P->rdiag = rdiag;
    P->ipiv = ipiv;
    P->fwd = blocked ? fwd : NULL;
    P->bwd = blocked ? bwd : NULL;
    P->r_value = rv;
    P->b = b;
    P->q = q;
    P->qh = F->exchange ? qh : NULL;
    P->w = w;
    P->s = s;
    P->z = z;
    return 0;
}

/* P's factors, tables, responses and compliance at lam, into `memory` (rk_form_size doubles);
 * P's other fields are the caller's. Returns 0; 1 + the column of a zero pivot; -1 if the
 * compliance is not positive; -2 if the end's temperature response to its heat loss is not
 * negative (a variable exchange). */
int rk_form(const rk_family *F, double lam, rk_problem *P, double *memory)
{
    if (F->kl == 3 && F->ku == 3)
        return form_at(F, lam, P, memory, 3, 3);
    if (F->kl == 2 && F->ku == 2)
        return form_at(F, lam, P, memory, 2, 2);
    return form_at(F, lam, P, memory, F->kl, F->ku);
}

#endif
