/*
 * kernel.c -- many steps of rodfem's `direct` method in one call (C99; built by rodfem/kernel.py).
 *
 * A step of DirectScheme (rodfem/direct.py) is, for the state s = [Theta; D; U] of n nodes,
 *
 *     rhs = R s + b                       (R: 2n x 3n, the right-hand sides [h; m])
 *     z   = C^-1 rhs                      (C: the coupled operator, factored once)
 *     c   = U(1),  s1 = c + z_U(1)        (U(1) without contact)
 *     p   = contact force (0 unless s1 > g, or c > g for the discrete gradient)
 *     x   = z + p q                       (q = C^-1 [0; -e], the response to a unit force)
 *     Theta += x_Theta,  u_prev = U,  U += x_U,  D = x_U  (Crank-Nicolson with inertia:
 *                                                          D = (x_U - D) + x_U)
 *
 * and the history row of the new state: U(1), D(1), U(0.5), the bulk energy 1/2 (E s + 2w).s and p.
 *
 * Everything here is in *node-interleaved* order, where the operators are banded with a small
 * band: the state is packed as s[3 i + k] (k = 0 Theta, 1 D, 2 U of node i), with g ghost nodes of
 * zeros on each side so that a row never branches at the ends; [dTheta; dU] as z[2 i + c]. R and
 * E are stored by "slots": a slot is one (offset into the packed state relative to 3 i) used by
 * some row of a component, and row i of component c keeps one value per slot of c (0 where that
 * row has no entry). Slots whose values are all exactly 0 are dropped: the sums are those of the
 * CSR products, term for term, in the CSR's column order, less exact zeros.
 *
 * C = P L U is LAPACK's dgbtrf of the interleaved operator (partial pivoting). The solve is
 * dgbtrs's algorithm: the forward pass applies the interchange ipiv[j] and the column j of L to
 * the rows below j (an axpy); the backward pass is dtbsv's column-oriented upper-triangular solve,
 * which finishes z[j] at column j, highest first. Its first column is dU(1) (x = 1 is the last
 * node), so the contact force p is known after one column, and each node's x = z + p q is final,
 * and the state updated, as soon as its two columns are done. So a step is two passes over the
 * nodes:
 *
 *   forward (ascending):   rows of R s + b computed just before the elimination reaches them
 *                          (kl rows ahead), and L's elimination;
 *   backward (descending): U's substitution, p after the first column, then per node x = z + p q,
 *                          the state update, and the energy rows of the node g_e above (those
 *                          need the new state of nodes i .. i + 2 g_e, all final by then).
 *
 * The superdiagonals of U beyond the last one with a non-zero entry, and the multipliers of L
 * likewise, are dropped by the caller (without pivoting U has only C's ku superdiagonals), and
 * U's diagonal is stored as its reciprocals (one multiplication in place of a division on the
 * backward pass's chain of dependences: the only rounding that differs from dgbtrs'). Without
 * interchanges (ipiv[j] = j for every j) the forward pass skips them.
 */
#include <math.h>
#include <stddef.h>

#include "contact.h"
#include "record.h"

/* The step's passes are instantiated with constant bands (rk_advance): force the inlining. */
#if defined(__GNUC__)
#define RK_INLINE static inline __attribute__((always_inline))
#else
#define RK_INLINE static inline
#endif

/* cdef begin: the declarations cffi reads (rodfem/kernel.py) */
typedef struct {
    int n;                 /* nodes */
    int ghost;             /* ghost nodes on each side of the packed state */
    /* the factors of the interleaved coupled operator, order N = 2n */
    int kl;                /* multipliers kept per column of L */
    int reach;             /* rows below a column that its elimination touches (kl or ipiv's) */
    int ku;                /* superdiagonals kept of U */
    int pivoting;          /* 0 if ipiv[j] = j for every j */
    const double *lower;   /* N x kl: lower[j kl + t] = L(j + 1 + t, j) */
    const double *upper;   /* N x ku: upper[j ku + t] = U(j - 1 - t, j) */
    const double *rdiag;   /* N: 1 / U(j, j) */
    const int *ipiv;       /* N: 0-based row interchanges of dgbtrf */
    /* the same factors as node-blocked recurrences (no interchanges only; else NULL) */
    const double *fwd;     /* n x (2 kl + 1): l_i, then F_i, rows 0 and 1, kl each */
    const double *bwd;     /* n x (2 ku + 3): d00, d01, d11, then H_i, rows 0 and 1, ku each */
    /* R and b, and E and 2w, are tables of distinct rows: node i reads row r_class[i] of
     * r_value and b (nodes whose rows of both are bitwise identical share it), and row
     * e_class[i] of e_value and two_w */
    const int *r_class;    /* n */
    const int *e_class;    /* n */
    /* R by slots: heat rows (component 0), then momentum rows (component 1) */
    int r_slots[2];
    const int *r_offset;   /* r_slots[0] + r_slots[1] */
    const double *r_value; /* r classes x (r_slots[0] + r_slots[1]) */
    const double *b;       /* r classes x 2 (heat, momentum) */
    const double *q;       /* 2n, interleaved: the response to a unit contact force */
    /* E by slots, components 0, 1, 2 of the state */
    int e_ghost;           /* node bandwidth of E */
    int e_slots[3];
    const int *e_offset;
    const double *e_value; /* e classes x (e_slots[0] + e_slots[1] + e_slots[2]) */
    const double *two_w;   /* e classes x 3 */
    /* the contact: the compliance w and the obstacle (contact.h) */
    double w;
    rc_obstacle obstacle;
    int midpoint_inertia;  /* D = 2 dU - D (Crank-Nicolson with inertia), else D = dU */
    /* positions in the packed state (ghosts not counted) of U(1), D(1) and around x = 0.5 */
    int u_1, du_1, half_i, half_j;
    double half_wi, half_wj;
    /* work: the packed state, 3 (n + 2 ghost), and z, 2n */
    double *s;
    double *z;
} rk_problem;

int rk_advance(const rk_problem *P, double *values, double *u_prev, long n0, long steps,
               double *rows, double *pressure);
/* cdef end */

#define KMAX 8

/* The loop bounds of a step: bands and slot counts. rk_advance passes constants for the common
 * cases, so that the inlined loops are unrolled with their offsets in registers. */
typedef struct {
    int blocked, kl, reach, ku, pivoting;
    int r0, r1, e0, e1, e2;
} shape;

/* Row c of node i (interleaved: 2 i + c) of R s + b; k = r_class[i]. */
RK_INLINE double rhs_row(const rk_problem *P, const double *sp, int i, int c, int k,
                         const shape S)
{
    const int first = c ? S.r0 : 0, count = c ? S.r1 : S.r0;
    const double *v = P->r_value + (size_t)k * (S.r0 + S.r1) + first;
    const int *o = P->r_offset + first;
    const double *base = sp + 3 * (ptrdiff_t)i;
    double sum = P->b[2 * (size_t)k + c];
#pragma GCC unroll 16
    for (int t = 0; t < count; t++)
        sum += v[t] * base[o[t]];
    return sum;
}

/* (E s + 2w).s over the three rows of node m. */
RK_INLINE double energy_rows(const rk_problem *P, const double *sp, int m, const shape S)
{
    const int count[3] = {S.e0, S.e1, S.e2};
    const int cm = P->e_class[m];
    const double *v = P->e_value + (size_t)cm * (S.e0 + S.e1 + S.e2);
    const int *o = P->e_offset;
    const double *base = sp + 3 * (ptrdiff_t)m;
    double part[3];
#pragma GCC unroll 3
    for (int k = 0; k < 3; k++) {
        double y = P->two_w[3 * (size_t)cm + k];
#pragma GCC unroll 16
        for (int t = 0; t < count[k]; t++)
            y += v[t] * base[o[t]];
        part[k] = y * base[k];
        v += count[k];
        o += count[k];
    }
    return part[0] + (part[1] + part[2]);
}

/* dgbtrs's forward pass: z = L^-1 P^T (R s + b), the rows of R s + b made just in time. */
RK_INLINE void forward(const rk_problem *P, const double *sp, double *z, const shape S)
{
    const int kl = S.kl, reach = S.reach, pivoting = S.pivoting;
    const int N = 2 * P->n;
    int next = 0;
    for (int j = 0; j < N; j++) {
        const int need = j + reach < N - 1 ? j + reach : N - 1;
        for (; next <= need; next++)
            z[next] = rhs_row(P, sp, next >> 1, next & 1, P->r_class[next >> 1], S);
        double t = z[j];
        if (pivoting) {
            const int l = P->ipiv[j];
            if (l != j) {
                t = z[l];
                z[l] = z[j];
                z[j] = t;
            }
        }
        const int lm = kl < N - 1 - j ? kl : N - 1 - j;
        const double *col = P->lower + (size_t)j * kl;
        for (int i = 0; i < lm; i++)
            z[j + 1 + i] -= col[i] * t;
    }
}

/* The state update of node i by x = z + p q, and (lagged) the energy rows of node i + e_ghost. */
RK_INLINE void accept_node(const rk_problem *P, double *sp, double *u_prev, int i,
                           double x_theta, double x_u, double p, double *energy, const shape S)
{
    if (p != 0.0) {
        x_theta += p * P->q[2 * (size_t)i];
        x_u += p * P->q[2 * (size_t)i + 1];
    }
    double *si = sp + 3 * (ptrdiff_t)i;
    si[0] += x_theta;
    if (u_prev)
        u_prev[i] = si[2];
    si[2] += x_u;
    si[1] = P->midpoint_inertia ? (x_u - si[1]) + x_u : x_u;
    if (i + P->e_ghost < P->n)
        *energy += energy_rows(P, sp, i + P->e_ghost, S);
}

RK_INLINE double contact(const rk_problem *P, const double *sp, double z_u_1)
{
    const double c = sp[P->u_1], s1 = c + z_u_1;
    if (rc_contact_needed(&P->obstacle, s1, c))
        return rc_solve(&P->obstacle, s1, P->w, c);
    return 0.0;
}

RK_INLINE void energy_tail(const rk_problem *P, const double *sp, double *energy, const shape S)
{
    for (int m = (P->e_ghost < P->n ? P->e_ghost : P->n) - 1; m >= 0; m--)
        *energy += energy_rows(P, sp, m, S);
}

/* dtbsv's backward pass, then the state update: returns p, and the new state's energy. */
RK_INLINE double backward(const rk_problem *P, double *sp, double *z, double *u_prev,
                          double *energy, const shape S)
{
    const int ku = S.ku;
    const int N = 2 * P->n;
    double p = 0.0;
    *energy = 0.0;
    for (int j = N - 1; j >= 0; j--) {
        const double t = z[j] * P->rdiag[j];
        z[j] = t;
        const int top = j < ku ? j : ku;
        const double *col = P->upper + (size_t)j * ku;
        for (int i = 0; i < top; i++)
            z[j - 1 - i] -= t * col[i];
        if (j == N - 1)
            p = contact(P, sp, t);
        if (!(j & 1))
            accept_node(P, sp, u_prev, j >> 1, z[j], z[j + 1], p, energy, S);
    }
    energy_tail(P, sp, energy, S);
    return p;
}


/* Without interchanges, L y = R s + b by nodes: the two unknowns of node i at once from those
 * of the nodes before it, y_i = A_i (R s + b)_i - F_i y_(2i-kl .. 2i-1), A_i = [[1, 0], [-l_i,
 * 1]] the inverse of L's diagonal block, F_i = A_i L_(i, 2i-kl .. 2i-1). The last kl values of
 * y are kept in registers, and the nearest are subtracted last: the chain of dependences from
 * node to node is one multiplication and one subtraction. */
RK_INLINE void forward_blocked(const rk_problem *P, const double *sp, double *z, const shape S)
{
    const int kl = S.kl;
    const int n = P->n;
    double win[KMAX + 2];
    for (int t = 0; t < kl; t++)
        win[t] = 0.0;
    for (int i = 0; i < n; i++) {
        const int k = P->r_class[i];
        const double z0 = rhs_row(P, sp, i, 0, k, S), z1 = rhs_row(P, sp, i, 1, k, S);
        const double *f = P->fwd + (size_t)i * (2 * kl + 1);
        double y0 = z0, y1 = z1 - f[0] * z0;
#pragma GCC unroll 8
        for (int t = 0; t < kl; t++) {
            y0 -= f[1 + t] * win[t];
            y1 -= f[1 + kl + t] * win[t];
        }
        z[2 * i] = y0;
        z[2 * i + 1] = y1;
        win[kl] = y0;
        win[kl + 1] = y1;
#pragma GCC unroll 8
        for (int t = 0; t < kl; t++)
            win[t] = win[t + 2];
    }
}

/* U x = y by nodes, from the last: x_i = D_i y_i - H_i x_(2i+2 .. 2i+1+ku), D_i the inverse of
 * U's diagonal block [[d00, -d01], [0, d11]], H_i = D_i U_(i, 2i+2 .. 2i+1+ku). The contact force
 * is known after the first node, each node's state updated as soon as it is solved. */
RK_INLINE double backward_blocked(const rk_problem *P, double *sp, const double *z,
                                  double *u_prev, double *energy, const shape S)
{
    const int ku = S.ku;
    const int n = P->n;
    double win[KMAX + 2], p = 0.0;
    *energy = 0.0;
    for (int t = 0; t < ku; t++)
        win[2 + t] = 0.0;
    for (int i = n - 1; i >= 0; i--) {
        const double *h = P->bwd + (size_t)i * (2 * ku + 3);
        const double y0 = z[2 * i], y1 = z[2 * i + 1];
        double x0 = h[0] * y0 - h[1] * y1, x1 = h[2] * y1;
#pragma GCC unroll 8
        for (int t = ku - 1; t >= 0; t--) {
            x0 -= h[3 + t] * win[2 + t];
            x1 -= h[3 + ku + t] * win[2 + t];
        }
        if (i == n - 1)
            p = contact(P, sp, x1);
        win[0] = x0;
        win[1] = x1;
#pragma GCC unroll 8
        for (int t = ku - 1; t >= 0; t--)
            win[2 + t] = win[t];
        accept_node(P, sp, u_prev, i, x0, x1, p, energy, S);
    }
    energy_tail(P, sp, energy, S);
    return p;
}

RK_INLINE void steps_loop(const rk_problem *P, double *u_prev, long n0, long steps,
                          double *rows, double *pressure, const shape S)
{
    double *sp = P->s + 3 * (ptrdiff_t)P->ghost, *z = P->z, p = 0.0;
    for (long k = 0; k < steps; k++) {
        double energy;
        double *last = k == steps - 1 ? u_prev : NULL;
        if (S.blocked) {
            forward_blocked(P, sp, z, S);
            p = backward_blocked(P, sp, z, last, &energy, S);
        } else {
            forward(P, sp, z, S);
            p = backward(P, sp, z, last, &energy, S);
        }
        double *row = rows + RAW_SLOTS * k;
        row[RAW_N] = (double)(n0 + k + 1);
        row[RAW_ITERATIONS] = 1.0;
        row[RAW_U_1] = sp[P->u_1];
        row[RAW_D_1] = sp[P->du_1];
        row[RAW_U_HALF] = P->half_wi * sp[P->half_i] + P->half_wj * sp[P->half_j];
        row[RAW_BULK_ENERGY] = 0.5 * energy;
        row[RAW_PRESSURE] = p;
    }
    *pressure = p;
}

/* `steps` steps from the state `values` = [Theta; D; U] (3n, block order), which is overwritten by
 * the last; u_prev (n) receives U of the step before the last, rows (steps x 7) the history rows
 * (n, 1, U(1), D(1), U(0.5), bulk energy, p) of the steps n0 + 1 .. n0 + steps, and *pressure
 * the last p. Returns 0. */
int rk_advance(const rk_problem *P, double *values, double *u_prev, long n0, long steps,
               double *rows, double *pressure)
{
    const int n = P->n, g = P->ghost;
    if (steps <= 0)
        return 0;
    for (int i = 0; i < 3 * g; i++) {
        P->s[i] = 0.0;
        P->s[3 * (size_t)(n + g) + i] = 0.0;
    }
    double *sp = P->s + 3 * (ptrdiff_t)g;
    for (int k = 0; k < 3; k++)
        for (int i = 0; i < n; i++)
            sp[3 * (size_t)i + k] = values[(size_t)k * n + i];
    /* The common cases get constant loop bounds (P1 with a != 0, b != 0; lumped or consistent
     * mass), the rest the same code with bounds read at run time. */
    const int blocked = P->fwd != NULL;
    const shape S = {blocked, P->kl, P->reach, P->ku, P->pivoting, P->r_slots[0], P->r_slots[1],
                     P->e_slots[0], P->e_slots[1], P->e_slots[2]};
#define RK_SHAPE(KL, R0, R1, E0, E1, E2) \
    (S.blocked && S.kl == KL && S.ku == KL && S.r0 == R0 && S.r1 == R1 && S.e0 == E0 && \
     S.e1 == E1 && S.e2 == E2)
    if (RK_SHAPE(3, 3, 7, 1, 1, 3)) {
        const shape C = {1, 3, 3, 3, 0, 3, 7, 1, 1, 3};
        steps_loop(P, u_prev, n0, steps, rows, pressure, C);
    } else if (RK_SHAPE(3, 3, 9, 3, 3, 3)) {
        const shape C = {1, 3, 3, 3, 0, 3, 9, 3, 3, 3};
        steps_loop(P, u_prev, n0, steps, rows, pressure, C);
    } else {
        steps_loop(P, u_prev, n0, steps, rows, pressure, S);
    }
#undef RK_SHAPE
    for (int k = 0; k < 3; k++)
        for (int i = 0; i < n; i++)
            values[(size_t)k * n + i] = sp[3 * (size_t)i + k];
    return 0;
}
