/*
 * direct.c -- many steps of rodfem's `direct` method in one call (C99; built by
 * rodfem/solver/compiled/direct.py).
 *
 * A step of DirectMethod (rodfem/solver/methods/direct.py) is, for the state s = [Theta; D; U] of
 * n nodes,
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
 * A redistributed mass (rodfem/solver/methods/massless.py, contact.h's rc_end) changes the end
 * x = 1 only: without its mass, D(1) = U^n(1) - U^(n-1)(1); eliminated (Crank-Nicolson, zeta =
 * 0), the law (in series with the last cell) is taken at the end's free position y, a row on
 * Theta and U of nodes n-2 and n-1: c = y of the old state, s1 = c + y's row on z, w and the
 * law those of y (set by the caller), and after the update the end is settled (U(1), D(1)) and
 * the force there is the step's recorded p (end.h).
 *
 * Everything here is in *node-interleaved* order, where the operators are banded with a small
 * band: the state is packed as s[3 i + k] (k = 0 Theta, 1 D, 2 U of node i), with g ghost nodes of
 * zeros on each side so that a row never branches at the ends; [dTheta; dU] as z[2 i + c]. R and
 * E are stored by "slots": a slot is one (offset into the packed state relative to 3 i) used by
 * some row of a component, and row i of component c keeps one value per slot of c (0 where that
 * row has no entry). Slots whose values are all exactly 0 are dropped: the sums are those of the
 * CSR products, term for term, in the CSR's column order, less exact zeros.
 *
 * C = P L U is LAPACK's dgbtrf of the interleaved operator (partial pivoting), and the solve is
 * dgbtrs's algorithm (band.h), whose backward pass finishes z[j] at column j, highest first. Its
 * first column is dU(1) (x = 1 is the last node), so the contact force p is known after one
 * column, and each node's x = z + p q is final, and the state updated, as soon as its two columns
 * are done (an eliminated end's p after the columns of nodes n-1 and n-2, whose update waits for
 * it). So a step is two passes over the nodes:
 *
 *   forward (ascending):   rows of R s + b computed just before the elimination reaches them
 *                          (kl rows ahead), and L's elimination;
 *   backward (descending): U's substitution, p after the first column, then per node x = z + p q,
 *                          the state update, and the energy rows of the node g_e above (those
 *                          need the new state of nodes i .. i + 2 g_e, all final by then).
 */
#include <math.h>
#include <stddef.h>

#include "contact.h"
#include "exchange.h"
#include "record.h"
#include "adaptive.h"

/* The step's passes are instantiated with constant bands (rk_advance): force the inlining. */
#if defined(__GNUC__)
#define RK_INLINE static inline __attribute__((always_inline))
#else
#define RK_INLINE static inline
#endif

/* cdef begin: the declarations cffi reads (rodfem/solver/compiled/direct.py) */
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
    const double *qh;      /* 2n, interleaved: the response to a unit heat loss at x = 1 (a
                              variable exchange only, else NULL) */
    rx_exchange exchange;  /* the heat exchange's law and the step's scalars (exchange.h) */
    /* E by slots, components 0, 1, 2 of the state */
    int e_ghost;           /* node bandwidth of E */
    int e_slots[3];
    const int *e_offset;
    const double *e_value; /* e classes x (e_slots[0] + e_slots[1] + e_slots[2]) */
    const double *two_w;   /* e classes x 3 */
    /* the contact: the compliance w and the obstacle (contact.h); an eliminated end's w and law
     * are those of its free position y */
    double w;
    rc_obstacle obstacle;
    rc_end end;            /* the end x = 1: with mass, without, or eliminated (contact.h) */
    int midpoint_inertia;  /* D = 2 dU - D (Crank-Nicolson with inertia), else D = dU */
    /* positions in the packed state (ghosts not counted) of U(1), D(1) and around x = 0.5 */
    int u_1, du_1, half_i, half_j;
    double half_wi, half_wj;
    int width;             /* a history row: RAW_SLOTS, then the readings */
    rr_readings readings;
    /* work: the packed state, 3 (n + 2 ghost), and z, 2n */
    double *s;
    double *z;
} rk_problem;

long rk_advance(const rk_problem *P, double *values, double *u_prev, long n0, long steps,
                double *rows, double *pressure);

/* The parts of a run's operators in Delta t (rodfem/solver/compiled/family_direct.py), from
 * which rk_form makes the rk_problem of a step size (direct_form.h). */
typedef struct {
    int n, kl, ku;         /* nodes; the band of the interleaved coupled operator C */
    const double *band;    /* C's parts P0, P1, P2 in LAPACK's band storage of C (column-major,
                              2 kl + ku + 1 rows, 2n columns), one after the other, 0 where C
                              has no entry (and in the kl rows of fill-in) */
    int r_classes, r_width;  /* the table of R: classes x slots */
    const double *r_parts; /* 3 x r_classes x r_width */
    const double *b_parts; /* 3 x r_classes x 2 */
    const double *e;       /* n: the load of a unit force at x = 1 */
    const double *end_row; /* 2n, interleaved: an eliminated end's free position on the unknowns,
                              else NULL */
    int u_1;               /* dU(1) in the interleaved unknowns */
    int exchange;          /* a variable heat exchange: q_h and its scalars too */
    int state;             /* the packed state's doubles, 3 (n + 2 ghost) */
    double *work;          /* rk_work_size doubles that every size shares: the band being
                              factored, and a step's packed state and z (one step at a time) */
} rk_family;

long rk_form_size(const rk_family *F);
long rk_work_size(const rk_family *F);
int rk_form(const rk_family *F, double lam, rk_problem *P, double *memory);
long rk_adaptive(ra_run *R, long max_steps);
/* cdef end */

/* The loop bounds of a step: bands and slot counts, and whether its row is recorded (record 0:
 * no row, and its energy not summed). rk_advance passes constants for the common cases, so that
 * the inlined loops are unrolled with their offsets in registers. */
typedef struct {
    int blocked, kl, reach, ku, pivoting;
    int r0, r1, e0, e1, e2;
    int record;
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

/* (E s + 2w).s over the three rows of node m (0 where no row is recorded). */
RK_INLINE double energy_rows(const rk_problem *P, const double *sp, int m, const shape S)
{
    if (!S.record)
        return 0.0;
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

/* The state update of node i by x = z + p q + phi q_h (phi = 0 but for a variable exchange).
 * An end without mass has no velocity of its own: D(1) = U^n(1) - U^(n-1)(1) (Method._accept);
 * `last` says whether i is that node, a constant 0 in the loops over the other nodes, so that
 * they do not test it. */
RK_INLINE void update_node(const rk_problem *P, double *sp, double *u_prev, int i,
                           double x_theta, double x_u, double p, double phi, int last)
{
    if (p != 0.0) {
        x_theta += p * P->q[2 * (size_t)i];
        x_u += p * P->q[2 * (size_t)i + 1];
    }
    if (phi != 0.0) {
        x_theta += phi * P->qh[2 * (size_t)i];
        x_u += phi * P->qh[2 * (size_t)i + 1];
    }
    double *si = sp + 3 * (ptrdiff_t)i;
    const double u_old = si[2];
    si[0] += x_theta;
    if (u_prev)
        u_prev[i] = u_old;
    si[2] += x_u;
    si[1] = P->midpoint_inertia ? (x_u - si[1]) + x_u : x_u;
    if (last && P->end.kind != RC_END_MASS)
        si[1] = si[2] - u_old;
}

/* The state update of node i, and (lagged) the energy rows of node i + e_ghost. */
RK_INLINE void accept_node(const rk_problem *P, double *sp, double *u_prev, int i,
                           double x_theta, double x_u, double p, double phi, int last,
                           double *energy, const shape S)
{
    update_node(P, sp, u_prev, i, x_theta, x_u, p, phi, last);
    if (i + P->e_ghost < P->n)
        *energy += energy_rows(P, sp, i + P->e_ghost, S);
}

/* The step's contact force p from the free increments of x = 1, and with a variable exchange
 * its flux *phi (exchange.h's rx_solve; *phi = 0 otherwise). Sets *failed where the exchange's
 * equation is not shown to have one root. */
RK_INLINE double contact(const rk_problem *P, const double *sp, double z_u_1, double z_theta_1,
                         double *phi, int *failed)
{
    const double c = sp[P->u_1], s1 = c + z_u_1;
    *phi = 0.0;
    if (P->exchange.law != RX_CONSTANT) {  /* Theta(1) sits two places before U(1) */
        const rx_exchange *X = &P->exchange;
        const double T0 = (sp[P->u_1 - 2] + X->offset) + X->weight * z_theta_1;
        double p = 0.0;
        *failed = rx_solve(X, &P->obstacle, P->w, s1, c, T0, &p, phi);
        return p;
    }
    if (rc_contact_needed(&P->obstacle, s1, c))
        return rc_solve(&P->obstacle, s1, P->w, c);
    return 0.0;
}

/* A node's two unknowns, (dTheta, dU), returned by value: nothing of the loops' takes an address,
 * so that all of it stays in registers. */
typedef struct {
    double theta, u;
} node_pair;

/* The two passes of a step, which read the rows and the node updates above: the eliminated end's
 * part (end.h), then the banded substitutions (band.h). */
#include "end.h"
#include "band.h"
#include "direct_form.h"

/* Returns the steps done: `steps`, or fewer where a step failed (a variable exchange's equation
 * without a root shown unique), the state then that of the last step done. A variable exchange
 * writes u_prev at every step, so that it is right wherever the loop stops. */
RK_INLINE long steps_loop(const rk_problem *P, double *u_prev, long n0, long steps,
                          double *rows, double *pressure, const shape S)
{
    double *sp = P->s + 3 * (ptrdiff_t)P->ghost, *z = P->z, p = *pressure;
    const int every = P->exchange.law != RX_CONSTANT;
    for (long k = 0; k < steps; k++) {
        double energy, step_p;
        int failed = 0;
        double *last = k == steps - 1 || every ? u_prev : NULL;
        if (S.blocked) {
            forward_blocked(P, sp, z, S);
            step_p = backward_blocked(P, sp, z, last, &energy, &failed, S);
        } else {
            forward(P, sp, z, S);
            step_p = backward(P, sp, z, last, &energy, &failed, S);
        }
        if (failed) {
            *pressure = p;
            return k;
        }
        p = step_p;
        if (!S.record)
            continue;
        double *row = rows + (ptrdiff_t)P->width * k;
        row[RAW_N] = (double)(n0 + k + 1);
        row[RAW_ITERATIONS] = 1.0;
        row[RAW_U_1] = sp[P->u_1];
        row[RAW_D_1] = sp[P->du_1];
        row[RAW_U_HALF] = P->half_wi * sp[P->half_i] + P->half_wj * sp[P->half_j];
        row[RAW_BULK_ENERGY] = 0.5 * energy;
        row[RAW_PRESSURE] = p;
        if (P->readings.count) {
            const double *const part[3] = {sp, sp + 1, sp + 2};
            rr_read(&P->readings, P->n, part, 3, row + RAW_SLOTS);
        }
    }
    *pressure = p;
    return steps;
}

/* `steps` steps from the state `values` = [Theta; D; U] (3n, block order), which is overwritten by
 * the last; u_prev (n) receives U of the step before the last, rows (steps x width) the history
 * rows (n, 1, U(1), D(1), U(0.5), bulk energy, p, the readings) of the steps n0 + 1 .. n0 + steps
 * (rows NULL: none, their energy not summed: the adaptive loop's steps, whose rows it records
 * itself), and *pressure (the method's p on entry) the last p. Returns the steps done (fewer than
 * `steps` where a step failed: steps_loop). */
long rk_advance(const rk_problem *P, double *values, double *u_prev, long n0, long steps,
                double *rows, double *pressure)
{
    const int n = P->n, g = P->ghost;
    long done = 0;
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
    /* The common cases get constant loop bounds (P1, b != 0; a != 0 or a = 0, lumped or
     * consistent mass, either redistributed or not), the rest the same code with bounds read at
     * run time. With a = 0 the band is narrower (kl = ku = 2: C is block diagonal, interleaved)
     * and the momentum rows of R read no Theta: without their own constants these cases ran the
     * generic loop, slower than the wider a != 0 (benchmarks/bench_kernel.py --shapes). */
    const int blocked = P->fwd != NULL, record = rows != NULL;
    const shape S = {blocked, P->kl, P->reach, P->ku, P->pivoting, P->r_slots[0], P->r_slots[1],
                     P->e_slots[0], P->e_slots[1], P->e_slots[2], record};
#define RK_SHAPE(KL, R0, R1, E0, E1, E2) \
    (S.blocked && S.kl == KL && S.ku == KL && S.r0 == R0 && S.r1 == R1 && S.e0 == E0 && \
     S.e1 == E1 && S.e2 == E2)
#define RK_CASE(KL, R0, R1, E0, E1, E2)                                               \
    if (RK_SHAPE(KL, R0, R1, E0, E1, E2)) {                                           \
        if (record) {                                                                 \
            const shape C = {1, KL, KL, KL, 0, R0, R1, E0, E1, E2, 1};                \
            done = steps_loop(P, u_prev, n0, steps, rows, pressure, C);               \
        } else {                                                                      \
            const shape C = {1, KL, KL, KL, 0, R0, R1, E0, E1, E2, 0};                \
            done = steps_loop(P, u_prev, n0, steps, rows, pressure, C);               \
        }                                                                             \
    } else
    RK_CASE(3, 3, 7, 1, 1, 3)
    RK_CASE(3, 3, 9, 3, 3, 3)
    RK_CASE(2, 3, 4, 1, 1, 3)
    RK_CASE(2, 3, 6, 3, 3, 3)
    done = steps_loop(P, u_prev, n0, steps, rows, pressure, S);
#undef RK_CASE
#undef RK_SHAPE
    for (int k = 0; k < 3; k++)
        for (int i = 0; i < n; i++)
            values[(size_t)k * n + i] = sp[3 * (size_t)i + k];
    return done;
}

/* The adaptive run's regular steps and events (adaptive.h), each step one rk_advance of its
 * size's problem without a row (the loop records the home state's row itself, the energy summed
 * in the stepper's order), the sizes formed by rk_form. */
#define RA_NAME rk_adaptive
#define RA_FORM(family, lam, problem, memory) \
    rk_form((const rk_family *)(family), lam, (rk_problem *)(problem), memory)
#define RA_STEP(problem, values, u_prev, n0, row, pressure, iterations) \
    (rk_advance((const rk_problem *)(problem), values, u_prev, n0, 1, NULL, pressure) == 1 && \
     (*(iterations) = 1, 1))
#include "adaptive.h"
