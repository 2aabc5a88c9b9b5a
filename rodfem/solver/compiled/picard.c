/*
 * picard_kernel.c -- many steps of rodfem's `picard` method in one call (C99; built by
 * rodfem/picard_kernel.py, which documents the algebra).
 *
 * A step of PicardScheme (rodfem/picard.py) from the state [Theta; D; U] of n nodes (node order,
 * x = 1 the last node), with every operator tridiagonal in node order:
 *
 *     [h; m] = R s + b                         once per step
 *     T = 0, V = 0                             (the iterates dTheta^{n,l}, dU^{n,l}, l = 0)
 *     for l = 1, 2, ...:
 *         p  = contact force of c + V(1), c = U(1)
 *         T' = A_h^-1 (h + N_du V)
 *         V' = A_m^-1 (m + N_dth T' - p e)
 *         change = max(|T' - T|_inf, |V' - V|_inf); T = T', V = V'
 *         stop if change < tol (converged), non-finite (failed) or l = max_iterations (failed)
 *     p = contact force of c + V(1); Theta += T, u_prev = U, U += V,
 *     D = V (Crank-Nicolson with inertia: D = (V - D) + V)
 *
 * A_h is factored L U (forward elimination ascending, back substitution descending), A_m U L
 * (elimination descending, substitution ascending), both normalised so that each recurrence is
 * one multiplication and one subtraction per node. Then an iteration is two fused sweeps over the
 * nodes (as benchmarks/picard_loop.c):
 *
 *   sweep B (descending): A_h's back substitution gives T'(i); one node behind, the momentum
 *                         right-hand side of node i + 1 (it needs T' at i .. i + 2) and A_m's
 *                         elimination;
 *   sweep A (ascending):  A_m's substitution gives V'(i); one node behind, the heat right-hand
 *                         side of the next iteration at node i - 1 and A_h's elimination (wasted
 *                         if this iteration converged).
 *
 * The two recurrences of a sweep are independent chains that the CPU overlaps. The mat-vecs sum
 * in the CSR's column order, as PETSc's MatMultAdd does; the substitutions round differently from
 * PETSc's LU (normalised factors, U L for A_m).
 *
 * A variable heat exchange (exchange.h) adds q (Theta(1) + offset) to the heat row of x = 1,
 * q = q(place of c + V(1), p) of the last iterate and Theta(1) taken implicitly, at the weight w:
 * by Sherman-Morrison with v = A_h^-1 e (PicardMethod.unit_response, from the PETSc loop),
 *     T' = z - phi v,  phi = q (Theta^(n-1)(1) + offset + w z(1)) / (1 + w q v(1)),
 * z the heat step without it. z(1) is sweep B's first value, so the sweep corrects as it goes.
 *
 * A redistributed mass (rodfem/solver/methods/massless.py, contact.h's rc_end) changes the end
 * only: without its mass, D(1) = U^n(1) - U^(n-1)(1). (An eliminated end needs a = 0, which this
 * loop leaves to the PETSc loop.)
 *
 * The rows of R and b, of N_du, N_dtheta and e, and of E and 2w repeat bit for bit between
 * nodes: each is a table of its distinct rows and a class (row number) per node, so an iteration
 * streams per node only the factor coefficients a sweep needs (3 doubles each way), a class
 * number and the vectors.
 */
#include <math.h>
#include <stddef.h>

#include "contact.h"
#include "exchange.h"
#include "record.h"
#include "adaptive.h"

/* cdef begin: the declarations cffi reads (rodfem/solver/compiled/picard.py) */
typedef struct {
    int n;                 /* nodes */
    int max_iterations;
    double tol;
    rc_obstacle obstacle;  /* the law and the time scheme's rule (contact.h) */
    rc_end end;            /* the end x = 1: with its mass or without (contact.h) */
    rx_exchange exchange;  /* the heat exchange's law (exchange.h) */
    const double *unit_response;  /* v = A_h^-1 e (n), for a variable exchange */
    int midpoint_inertia;  /* D = 2 dU - D (Crank-Nicolson with inertia), else D = dU */
    /* Tables of distinct rows, with each node's row number (its class) in *_class: */
    /* rows of 20: the heat row of R (blocks Theta, D, U; each (i-1, i, i+1)), b_h, then the
     * momentum row of R likewise, b_m */
    const int *fixed_class;
    const double *fixed;
    int blocks[6];         /* which of these six blocks have a non-zero entry */
    /* rows of 8: N_du's row (i-1, i, i+1), N_dtheta's row, e(i), 0 */
    const int *coupling_class;
    const double *coupling;
    /* rows of 12: the rows of the blocks M, bM/dt^2, K of E (i-1, i, i+1), then 2w for
     * Theta, D, U */
    const int *energy_class;
    const double *energy;
    /* per node, rows of 3, as the sweeps read them: descending (hcp, mp, mq), ascending
     * (mcq, hp, hq); A_h's factor is (hp, hq, hcp), A_m's (mp, mq, mcq) */
    const double *descending;
    const double *ascending;
    /* the nodes around x = 0.5 (U(0.5) = half_wi U(half_i) + half_wj U(half_j)) */
    int half_i, half_j;
    double half_wi, half_wj;
    int width;             /* a history row: RAW_SLOTS, then the readings */
    rr_readings readings;
    /* 10 (n + 2) doubles of work: Theta, D, U, u_prev, T, V, h, m, gH, gM, each with a zero
     * ghost entry on either side */
    double *work;
} pk_problem;

int pk_factor(int n, const double *lo, const double *diag, const double *up, int ul,
              double *out, int stride);
long pk_advance(const pk_problem *P, double *values, double *u_prev, long n0, long steps,
                double *rows, double *pressure, int *iterations, double *increment,
                double *last_u_1);

/* The parts of a run's operators in Delta t (rodfem/solver/compiled/family_picard.py), from
 * which pk_form makes the pk_problem of a step size (picard_form.h). */
typedef struct {
    int n;
    int fixed_classes, coupling_classes;
    const double *fixed_parts;     /* 3 x fixed_classes x 20 */
    const double *coupling_parts;  /* 3 x coupling_classes x 8 */
    const double *operator_parts;  /* 3 x 6n: A_h's lower, diagonal, upper, then A_m's */
} pk_family;

long pk_form_size(const pk_family *F);
int pk_form(const pk_family *F, double lam, pk_problem *P, double *memory);
long pk_adaptive(ra_run *R, long max_steps);
/* cdef end */

/* The tridiagonal factor of (lo, diag, up), normalised: ul = 0, L U, eliminating ascending:
 *   m_i = d_i - lo_i cp_(i-1), p_i = 1/m_i, q_i = lo_i/m_i, cp_i = up_i/m_i;
 * ul = 1, U L, eliminating descending:
 *   m_i = d_i - up_i cp_(i+1), p_i = 1/m_i, q_i = up_i/m_i, cp_i = lo_i/m_i.
 * Written to out[stride i + 0, 1, 2]. Returns 0, or 1 + the node of a zero pivot. */
int pk_factor(int n, const double *lo, const double *diag, const double *up, int ul,
              double *out, int stride)
{
    double cp = 0.0;
    for (int k = 0; k < n; k++) {
        const int i = ul ? n - 1 - k : k;
        const double towards = ul ? up[i] : lo[i], away = ul ? lo[i] : up[i];
        const double m = diag[i] - towards * cp;
        if (m == 0.0 || !isfinite(m))
            return i + 1;
        double *o = out + (size_t)stride * i;
        o[0] = 1.0 / m;
        o[1] = towards / m;
        o[2] = away / m;
        cp = o[2];
    }
    return 0;
}

#include "picard_form.h"

/* One 3-term row (i-1, i, i+1) added to sum in that order. */
#define ROW3(sum, a, x, i) \
    ((((sum) + (a)[0] * (x)[(i) - 1]) + (a)[1] * (x)[i]) + (a)[2] * (x)[(i) + 1])

/* Row i of [h; m] = R s + b (the blocks of R that are not all zero, in CSR column order), and
 * A_h's elimination of h at node i (the heat rhs of l = 1, where V = 0). */
static inline void fixed_row(const pk_problem *P, int i, const double *th, const double *D,
                             const double *U, double *h, double *m, double *gH, double *gh)
{
    const double *f = P->fixed + 20 * (size_t)P->fixed_class[i];
    const int *blocks = P->blocks;
    double s = f[9], r = f[19];
    if (blocks[0])
        s = ROW3(s, f, th, i);
    if (blocks[1])
        s = ROW3(s, f + 3, D, i);
    if (blocks[2])
        s = ROW3(s, f + 6, U, i);
    if (blocks[3])
        r = ROW3(r, f + 10, th, i);
    if (blocks[4])
        r = ROW3(r, f + 13, D, i);
    if (blocks[5])
        r = ROW3(r, f + 16, U, i);
    h[i] = s;
    m[i] = r;
    const double *hh = P->ascending + 3 * (size_t)i + 1;
    *gh = s * hh[0] - hh[1] * *gh;
    gH[i] = *gh;
}

/* Node i's part of (E s + 2w).s, per block. */
static inline void energy_row(const pk_problem *P, int i, const double *th, const double *D,
                              const double *U, double *e)
{
    const double *E = P->energy + 12 * (size_t)P->energy_class[i];
    e[0] += ROW3(E[9], E, th, i) * th[i];
    e[1] += ROW3(E[10], E + 3, D, i) * D[i];
    e[2] += ROW3(E[11], E + 6, U, i) * U[i];
}

/* The update of node i by the step's increments T, V; u_prev (up) takes U first. */
static inline void accept_node(double *restrict th, double *restrict D, double *restrict U,
                               double *restrict up, const double *restrict T,
                               const double *restrict V, int i, int midpoint_inertia)
{
    th[i] += T[i];
    up[i] = U[i];
    U[i] += V[i];
    D[i] = midpoint_inertia ? (V[i] - D[i]) + V[i] : V[i];
}

long pk_advance(const pk_problem *P, double *values, double *u_prev_out, long n0, long steps,
                double *rows, double *pressure, int *iterations, double *increment,
                double *last_u_1)
{
    const int n = P->n, max_it = P->max_iterations;
    const size_t stride = (size_t)n + 2;
    double *w = P->work;
    for (size_t i = 0; i < 10 * stride; i++)
        w[i] = 0.0;
    double *restrict th = w + 1, *restrict D = w + stride + 1, *restrict U = w + 2 * stride + 1;
    double *restrict up = w + 3 * stride + 1, *restrict T = w + 4 * stride + 1;
    double *restrict V = w + 5 * stride + 1, *restrict h = w + 6 * stride + 1;
    double *restrict m = w + 7 * stride + 1, *restrict gH = w + 8 * stride + 1;
    double *restrict gM = w + 9 * stride + 1;
    for (int i = 0; i < n; i++) {
        th[i] = values[i];
        D[i] = values[n + i];
        U[i] = values[2 * (size_t)n + i];
        up[i] = u_prev_out[i];
    }
    const double tol = P->tol;
    const double *restrict fd = P->descending, *restrict fa = P->ascending;
    const double *restrict cpl = P->coupling;
    const int *restrict cc = P->coupling_class;
    const int midpoint_inertia = P->midpoint_inertia;
    const int massless = P->end.kind != RC_END_MASS;
    const int variable = P->exchange.law != RX_CONSTANT;
    const double weight = P->exchange.weight, *restrict v = P->unit_response;
    long done = 0;
    int its = *iterations;
    double p = *pressure, inc = 0.0;

    /* the first step's fixed parts; each accepted step makes the next one's */
    {
        double gh = 0.0;
        for (int i = 0; i < n; i++)
            fixed_row(P, i, th, D, U, h, m, gH, &gh);
    }
    for (long k = 0; k < steps; k++) {
        const double c = U[n - 1], theta_end = th[n - 1] + P->exchange.offset;
        int l;
        int failed = 0;
        for (int i = 0; i < n; i++) {
            T[i] = 0.0;
            V[i] = 0.0;
        }
        double deepest = c;  /* the largest U(1) of the iterates, for the failure's message */
        for (l = 1; l <= max_it; l++) {
            deepest = c + V[n - 1] > deepest ? c + V[n - 1] : deepest;
            const double force = rc_contact_force(&P->obstacle, c + V[n - 1], c);
            const double q = -force;
            double ct, cu, bad, e;
            /* the exchange's flux phi of the heat step without it, z; T' = z - phi v */
            double z1 = gH[n - 1], phi = 0.0;
            if (variable) {
                const double qx = rx_extra(&P->exchange, rx_place(&P->exchange, c + V[n - 1], c),
                                           force);
                if (qx != 0.0)
                    phi = qx * (theta_end + weight * z1) / (1.0 + weight * qx * v[n - 1]);
            }
            /* sweep B, descending: T' by A_h's substitution; momentum rhs and elimination one
             * node behind (x1 = T'(i + 1), x2 = T'(i + 2)) */
            double x1 = phi != 0.0 ? z1 + -phi * v[n - 1] : z1, x2 = 0.0, gm = 0.0;
            e = fabs(x1 - T[n - 1]);
            ct = e;
            bad = e;
            T[n - 1] = x1;
            for (int i = n - 2; i >= 0; i--) {
                const double zi = gH[i] - fd[3 * (size_t)i] * z1;
                const double ti = phi != 0.0 ? zi + -phi * v[i] : zi;
                z1 = zi;
                e = fabs(ti - T[i]);
                ct = e > ct ? e : ct;
                bad += e;
                T[i] = ti;
                const double *mm = fd + 3 * (size_t)(i + 1) + 1;
                const double *nn = cpl + 8 * (size_t)cc[i + 1] + 3;
                double r = ((m[i + 1] + nn[0] * ti) + nn[1] * x1) + nn[2] * x2;
                r += q * nn[3];
                gm = r * mm[0] - mm[1] * gm;
                gM[i + 1] = gm;
                x2 = x1;
                x1 = ti;
            }
            {
                const double *mm = fd + 1, *nn = cpl + 8 * (size_t)cc[0] + 3;
                double r = ((m[0] + nn[0] * 0.0) + nn[1] * x1) + nn[2] * x2;
                r += q * nn[3];
                gm = r * mm[0] - mm[1] * gm;
                gM[0] = gm;
            }
            /* sweep A, ascending: V' by A_m's substitution; the next heat rhs and elimination
             * one node behind (y1 = V'(i - 1), y2 = V'(i - 2)) */
            double y1 = gM[0] - fa[0] * 0.0, y2 = 0.0, gh = 0.0;
            e = fabs(y1 - V[0]);
            cu = e;
            bad += e;
            V[0] = y1;
            for (int i = 1; i < n; i++) {
                const double di = gM[i] - fa[3 * (size_t)i] * y1;
                e = fabs(di - V[i]);
                cu = e > cu ? e : cu;
                bad += e;
                V[i] = di;
                const double *hh = fa + 3 * (size_t)(i - 1) + 1;
                const double *nn = cpl + 8 * (size_t)cc[i - 1];
                const double r = ((h[i - 1] + nn[0] * y2) + nn[1] * y1) + nn[2] * di;
                gh = r * hh[0] - hh[1] * gh;
                gH[i - 1] = gh;
                y2 = y1;
                y1 = di;
            }
            {
                const double *hh = fa + 3 * (size_t)(n - 1) + 1;
                const double *nn = cpl + 8 * (size_t)cc[n - 1];
                const double r = ((h[n - 1] + nn[0] * y2) + nn[1] * y1) + nn[2] * 0.0;
                gh = r * hh[0] - hh[1] * gh;
                gH[n - 1] = gh;
            }
            if (!isfinite(bad)) { /* inf or nan: stop at once */
                inc = NAN;
                failed = 1;
                break;
            }
            inc = cu > ct ? cu : ct;
            if (inc < tol)
                break;
        }
        if (l > max_it) {
            l = max_it;
            failed = 1;
        }
        if (failed) {
            its = l;
            *last_u_1 = deepest;
            break;
        }
        p = rc_contact_force(&P->obstacle, c + V[n - 1], c);
        /* accept node i; then, one node behind (they read node i), the energy row of node
         * i - 1 and the next step's fixed parts there */
        double energy[3] = {0.0, 0.0, 0.0}, gh = 0.0;
        accept_node(th, D, U, up, T, V, 0, midpoint_inertia);
        for (int i = 1; i < n - 1; i++) {
            accept_node(th, D, U, up, T, V, i, midpoint_inertia);
            energy_row(P, i - 1, th, D, U, energy);
            fixed_row(P, i - 1, th, D, U, h, m, gH, &gh);
        }
        /* the end, before the rows that read it: without mass it has no velocity of its own,
         * D(1) = U^n(1) - U^(n-1)(1) */
        accept_node(th, D, U, up, T, V, n - 1, midpoint_inertia);
        if (massless)
            D[n - 1] = U[n - 1] - up[n - 1];
        energy_row(P, n - 2, th, D, U, energy);
        fixed_row(P, n - 2, th, D, U, h, m, gH, &gh);
        energy_row(P, n - 1, th, D, U, energy);
        fixed_row(P, n - 1, th, D, U, h, m, gH, &gh);
        double *row = rows + (ptrdiff_t)P->width * k;
        row[RAW_N] = (double)(n0 + k + 1);
        row[RAW_ITERATIONS] = (double)l;
        row[RAW_U_1] = U[n - 1];
        row[RAW_D_1] = D[n - 1];
        row[RAW_U_HALF] = P->half_wi * U[P->half_i] + P->half_wj * U[P->half_j];
        row[RAW_BULK_ENERGY] = 0.5 * ((energy[0] + energy[1]) + energy[2]);
        row[RAW_PRESSURE] = p;
        if (P->readings.count) {
            const double *const part[3] = {th, D, U};
            rr_read(&P->readings, n, part, 1, row + RAW_SLOTS);
        }
        its = l;
        done = k + 1;
    }
    for (int i = 0; i < n; i++) {
        values[i] = th[i];
        values[n + i] = D[i];
        values[2 * (size_t)n + i] = U[i];
        u_prev_out[i] = up[i];
    }
    *pressure = p;
    *iterations = its;
    *increment = inc;
    return done;
}

/* The adaptive run's regular steps and events (adaptive.h), each step one pk_advance of its
 * size's problem (its iterations those its row records), the sizes an event tries formed by
 * pk_form. */
static int pk_one_step(const void *problem, double *values, double *u_prev, long n0,
                       double *row, double *pressure, int *iterations)
{
    double increment, last_u_1;
    if (pk_advance((const pk_problem *)problem, values, u_prev, n0, 1, row, pressure,
                   iterations, &increment, &last_u_1) != 1)
        return 0;
    *iterations = (int)row[RAW_ITERATIONS];
    return 1;
}

#define RA_NAME pk_adaptive
#define RA_FORM(family, lam, problem, memory) \
    pk_form((const pk_family *)(family), lam, (pk_problem *)(problem), memory)
#define RA_STEP pk_one_step
#include "adaptive.h"
