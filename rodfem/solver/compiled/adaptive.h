/*
 * adaptive.h -- the regular steps of an adaptive run in compiled code: the step, its error
 * estimate (Milne's device), the PI controller, the step ladder and the history row, for many
 * steps in one call. rodfem/solver/adaptive/stepper.py and control.py in C, formula for formula,
 * so that a step here is decided as it is there (rodfem/solver/adaptive/compiled.py says what
 * is handed back and why).
 *
 * Included by direct.c and picard.c twice: first for its types and helpers (cffi is told of
 * ra_run, from this header's cdef block), then at their end, after defining
 *     RA_NAME   the exported function (rk_adaptive, pk_adaptive), declared in its cdef, and
 *     RA_STEP(problem, values, u_prev, n0, row, pressure, iterations)
 *               one step of its method from the state values = [Theta; D; U] (block order),
 *               an expression that is 1 if the step was done, 0 if it failed (the state then
 *               untouched or to be restored);
 * which instantiates the loop below as RA_NAME.
 *
 * The estimate's restarts (fewer than order + 1 states since the start or the last event) are
 * taken here too, as the stepper takes them: the step, then the same step again as two halves,
 * their difference the error (AdaptiveStepper._halves), the two halves accepted with a row each;
 * a half that changes contact rejects the step, as an infinite error.
 *
 * A step size with no problem yet is formed here, from the run's family of step sizes (RA_FORM,
 * no Python between), in a pool of slots the caller allocated and wrote once: the least recently
 * used slot is formed again. A size's problem is the same bit for bit wherever and whenever it
 * is formed, so the pool changes no decision.
 *
 * What it does not do, handing the run back to Python with the state of the last accepted step
 * (rodfem/solver/adaptive/compiled.py): a step that changes contact where no step sizes can be
 * formed here (an event, located there), a step of a size it has no problem for and cannot form
 * (made there), a step the method does not solve, a restart it does not take (RA_RESTART: one
 * whose step changes contact, whose step or a half fails, whose first half begins a save interval
 * or has a row that is not finite, whose half has no problem and is off the ladder, or with room
 * for fewer than two rows), and a step size below dt_min. The paper scheme's special first step
 * never comes here.
 */
#ifndef RODFEM_ADAPTIVE_H
#define RODFEM_ADAPTIVE_H

#include <math.h>
#include <stddef.h>
#include <string.h>

#include "contact.h"
#include "record.h"

/* cdef begin: the declarations cffi reads */
enum {
    RA_END = 0,       /* t reached the end */
    RA_PAUSE = 1,     /* rows full, a save interval begun, a non-finite row, or max_steps done */
    RA_NEED = 2,      /* no problem for the step size `wanted` */
    RA_EVENT = 3,     /* the step tried changes contact (where it is not located here) */
    RA_FAILED = 4,    /* the method did not solve the step tried */
    RA_RESTART = 5,   /* a restart of the estimate (two halves) the stepper takes */
    RA_TOO_SMALL = 6  /* the next step, after a rejection, is below dt_min */
};

typedef struct {
    int n;                 /* nodes: the state has 3n values, y = [state; p] 3n + 1 */
    int order;             /* the scheme's order, 1 (paper) or 2 (Crank-Nicolson) */
    /* contact is on where u(1) - gap (+ cell p for the rigid obstacle) > 0 */
    int rigid;
    double gap, cell;
    /* the contact force measured: the step's p, or (end_force) the obstacle's force at U(1),
     * the state's own (AdaptiveStepper.y: Crank-Nicolson's step force is a discrete gradient) */
    int end_force;
    rc_obstacle obstacle;
    /* the controller: Delta t_0, the bounds (dt_max 0: none), tolerance, the end; the next
     * step's size h, the last accepted error, Picard's cap in contact, the time */
    double dt0, dt_min, dt_max, tolerance, end;
    double h, previous, cap, t;
    /* the norm: b (the velocity's scale S/sqrt(b)), an end without mass (D(1) left out), whether
     * p is measured, the largest sizes so far (Theta, D, U, stress) */
    double b;
    int massless_end, force;
    /* whether the measured p jumps at an impact (AdaptiveStepper.jumps): the estimate then
     * restarts without the event's own state */
    int jumps;
    double maxima[4];
    /* the accepted states since the last restart, a ring of order + 1 places: the k-th oldest
     * (k < count) is past + ((head + k) % (order + 1)) (3n + 1), at the time past_t[same] */
    int count, head;
    double past_t[3];
    double *past;
    /* the problems of the step sizes at hand: size_h[k], size_problem[k], k < sizes */
    int sizes;
    const double *size_h;
    void *const *size_problem;
    /* the home method's state: values = [Theta; D; U] (3n), U of the step before, its step n,
     * iterations and contact force */
    double *values;
    double *u_prev;
    long step;
    int iterations;
    double pressure;
    /* the history row of the home state: the raw slots and the readings (record.h); the bulk
     * energy 1/2 (E s + 2w).s, E tridiagonal: e_band[3 i + 0, 1, 2] = E(i, i - 1), E(i, i),
     * E(i, i + 1) (0 outside E and where E has no entry) */
    int width;
    int u_1, du_1, half_i, half_j;
    double half_wi, half_wj;
    rr_readings readings;
    const double *e_band;
    const double *two_w;
    /* where the rows go (room of them: raw rows, and (t, dt, event) per row), and when to stop:
     * the save interval's length (0: none) and the number of the last one saved */
    double *rows;
    double *clock;
    long room;
    double interval;
    double frame;
    /* work: 3n for the start's values, n for its u_prev, 3n for the error's squares, width
     * for a method's own row */
    double *start;
    double *start_u_prev;
    double *squares;
    double *scratch_row;
    /* a restart's work: the whole step's y (3n + 1), and the start of the step while the second
     * half starts from the first (3n values and n of u_prev) */
    double *whole;
    double *held;
    /* an event's tries, of sizes off the table, formed here (RA_FORM) from the run's family of
     * step sizes: a copy of the template problem (problem_bytes) completed in one of two scratch
     * problems and their memory; family NULL: events are handed back */
    const void *family;
    const void *template_problem;
    long problem_bytes;
    void *scratch[2];
    double *scratch_memory[2];
    double event_width, event_past;
    /* the step sizes formed here (family not NULL): a pool of `pool` slots, each a problem
     * (pool_problem[k], completed from a copy of the template) with its memory (pool_memory[k],
     * the family's size), holding the step pool_h[k] (0: none), last used at the count
     * pool_used[k] (the least recently used slot is formed again); formed counts them */
    int pool;
    double *pool_h;
    long *pool_used;
    void *const *pool_problem;
    double *const *pool_memory;
    long uses;
    long formed;
    /* what happened: the rows written, the steps rejected, the events located, the size wanted
     * (RA_NEED) or the size rejected (RA_TOO_SMALL) */
    long written;
    long rejected;
    long events;
    double wanted;
} ra_run;
/* cdef end */

#define RA_RUNGS 4
#define RA_SAFETY 0.9
#define RA_GROW 5.0
#define RA_SHRINK 0.2
#define RA_TINY 1e-10

/* Python's max(a, b) and min(a, b): a unless b is strictly larger (smaller). */
static inline double ra_pymax(double a, double b) { return b > a ? b : a; }
static inline double ra_pymin(double a, double b) { return b < a ? b : a; }
/* NumPy's maximum: NaN if either is. */
static inline double ra_npmax(double a, double b)
{
    if (isnan(a) || isnan(b))
        return NAN;
    return a > b ? a : (b > a ? b : a);
}

/* NumPy's pairwise sum of x[0 .. n-1] (numpy/core/src/umath/loops_utils.h), the order in which
 * np.add.reduce sums a contiguous row: the same result bit for bit. */
static double ra_pairwise(const double *x, long n)
{
    if (n < 8) {
        double r = 0.0;
        for (long i = 0; i < n; i++)
            r += x[i];
        return r;
    }
    if (n <= 128) {
        double r[8];
        long i;
        for (int j = 0; j < 8; j++)
            r[j] = x[j];
        for (i = 8; i < n - (n % 8); i += 8)
            for (int j = 0; j < 8; j++)
                r[j] += x[i + j];
        double res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]));
        for (; i < n; i++)
            res += x[i];
        return res;
    }
    long n2 = n / 2;
    n2 -= n2 % 8;
    return ra_pairwise(x, n2) + ra_pairwise(x + n2, n - n2);
}

/* control.py's rung: the largest step of the ladder dt0 2^(j/RUNGS) that is at most h. */
static inline double ra_rung(double dt0, double h)
{
    const double j = floor(RA_RUNGS * log2(h / dt0) + 1e-9);
    const double step = dt0 * pow(2.0, j / RA_RUNGS);
    return step <= h ? step : dt0 * pow(2.0, (j - 1.0) / RA_RUNGS);
}

/* Controller.ladder */
static inline double ra_ladder(const ra_run *R, double h)
{
    if (R->dt_max != 0.0)
        h = ra_pymin(h, R->dt_max);
    return ra_pymax(ra_rung(R->dt0, h), ra_pymin(R->dt_min, h));
}

/* AdaptiveStepper._proposal */
static inline double ra_proposal(const ra_run *R, int touching)
{
    const double h = ra_ladder(R, touching ? ra_pymin(R->h, R->cap) : R->h);
    const double left = R->end - R->t;
    return h >= left * (1.0 - 1e-9) ? left : h;
}

/* AdaptiveStepper._contact: > 0 while the obstacle pushes. */
static inline double ra_contact(const ra_run *R, double u_1, double p)
{
    return R->rigid ? (u_1 - R->gap) + R->cell * p : u_1 - R->gap;
}

/* Controller.accepted: the step after an accepted step h of the given error (R->previous
 * becomes it). */
static inline double ra_accepted(ra_run *R, double h, double error)
{
    const int k = R->order + 1;
    error = ra_pymax(error, RA_TINY);
    const double factor = RA_SAFETY * pow(error, -0.7 / k) *
                          pow(ra_pymax(R->previous, RA_TINY), 0.4 / k);
    R->previous = error;
    return h * ra_pymin(RA_GROW, ra_pymax(RA_SHRINK, factor));
}

/* Controller.rejected: the step to try after a rejected step h of the given error. */
static inline double ra_rejected(const ra_run *R, double h, double error)
{
    const double factor = RA_SAFETY * pow(ra_pymax(error, RA_TINY), -1.0 / (R->order + 1));
    return h * ra_pymin(RA_SAFETY, ra_pymax(RA_SHRINK, factor));
}

/* AdaptiveStepper._reject of the step h (home restored by the caller): counted, the next size
 * set; RA_TOO_SMALL where it is below dt_min (R->wanted = h), else -2. */
static inline long ra_reject(ra_run *R, double h, double error)
{
    R->rejected++;
    R->h = ra_rejected(R, h, error);
    if (R->h < R->dt_min) {
        R->wanted = h;
        return RA_TOO_SMALL;
    }
    return -2;
}

/* AdaptiveStepper._accept's time after a step h from t (the end itself within 1e-12 of it). */
static inline double ra_after(const ra_run *R, double t, double h)
{
    return fabs(R->end - (t + h)) <= 1e-12 * R->end ? R->end : t + h;
}

/* The ring's place for a new accepted state (past.append, the oldest dropped beyond
 * order + 1). */
static inline int ra_place(ra_run *R)
{
    const int places = R->order + 1;
    if (R->count < places)
        return (R->head + R->count++) % places;
    const int at = R->head;
    R->head = (R->head + 1) % places;
    return at;
}

/* One pass over the state s for the estimate: the squares of the scaled differences from the
 * extrapolation, e = (s - sum_i states[i] weight[i]) factor (the sum from 0 in the order of i:
 * 0 + x is x but for the sign of a zero, which e^2 drops), and the sizes ErrorNorm.sizes reads
 * off s: the largest |Theta|, |D| (but an end without mass), |U| and |U(i) - U(i - 1)|, each
 * NaN where one is (four running maxima a block, a maximum being the same in any order). With
 * k = 0 the sizes alone (states, weight and sq unused). */
__attribute__((always_inline))  /* each caller's k a constant: its own loop */
static inline void ra_differences(int n, const double *restrict s, const double *const *states,
                                  const double *weight, double factor, const int k,
                                  int massless_end, double *restrict sq, double largest[3],
                                  double *jump)
{
    const double *restrict a = k ? states[0] : s, *restrict b = k ? states[1] : s;
    const double *restrict c = k == 3 ? states[2] : b;
    const double wa = k ? weight[0] : 0.0, wb = k ? weight[1] : 0.0, wc = k == 3 ? weight[2] : 0.0;
    for (int block = 0; block < 3; block++) {
        double m[4] = {0.0, 0.0, 0.0, 0.0}, mj[4] = {0.0, 0.0, 0.0, 0.0};
        int bad = 0, badj = 0;
        const int first = block * n, count = block == 1 && massless_end ? n - 1 : n;
        for (int i = 0; i < n; i++) {
            const int at = first + i;
            if (k) {
                const double x = a[at] * wa + b[at] * wb;
                const double e = (s[at] - (k == 3 ? x + c[at] * wc : x)) * factor;
                sq[at] = e * e;
            }
            const double v = i < count ? fabs(s[at]) : 0.0;
            m[i & 3] = v > m[i & 3] ? v : m[i & 3];
            bad |= v != v;
            if (block == 2 && i > 0) {
                const double d = fabs(s[at] - s[at - 1]);
                mj[i & 3] = d > mj[i & 3] ? d : mj[i & 3];
                badj |= d != d;
            }
        }
        const double p = m[0] > m[1] ? m[0] : m[1], q = m[2] > m[3] ? m[2] : m[3];
        largest[block] = bad ? NAN : (p > q ? p : q);
        if (block == 2) {
            const double pj = mj[0] > mj[1] ? mj[0] : mj[1], qj = mj[2] > mj[3] ? mj[2] : mj[3];
            *jump = badj ? NAN : (pj > qj ? pj : qj);
        }
    }
}

/* ErrorNorm.grown: the maxima with y's sizes counted (its fields' largest, jump the largest
 * |U(i) - U(i - 1)|, p its force), NaN where either is. */
static inline void ra_grow(const ra_run *R, const double fields[3], double jump, double p,
                           double grown[4])
{
    const double sizes[4] = {fields[0], fields[1], fields[2],
                             ra_pymax(fabs(p), R->n > 1 ? jump / R->cell : 0.0)};
    for (int c = 0; c < 4; c++)
        grown[c] = ra_npmax(R->maxima[c], sizes[c]);
}

static double ra_norm(const ra_run *R, const double *sq, double e_p, const double grown[4]);

/* AdaptiveStepper._predicted: the local error of the step h just taken (to y = [s; p]), by
 * Milne's device from the last order + 1 states (control.py's extrapolate and milne), in
 * ErrorNorm's norm, p's error counted where `measured` (not at an event where p jumps). The
 * sums are NumPy's: the extrapolation from 0 term by term, the squares pairwise. */
static double ra_predicted(ra_run *R, double h, const double *s, double p, int measured,
                           double grown[4])
{
    const int n = R->n, k = R->order + 1, size = 3 * n + 1, places = R->order + 1;
    const double t = R->t + h;
    double times[3], weight[3];
    const double *states[3];
    for (int i = 0; i < k; i++) {
        const int at = (R->head + (R->count - k) + i) % places;
        times[i] = R->past_t[at];
        states[i] = R->past + (size_t)at * size;
    }
    for (int i = 0; i < k; i++) {
        weight[i] = 1.0;
        for (int j = 0; j < k; j++)
            if (j != i)
                weight[i] *= (t - times[j]) / (times[i] - times[j]);
    }
    double factor;
    if (R->order == 1) {
        factor = h / (2.0 * h + (times[1] - times[0]));
    } else {
        const double g0 = times[2] - times[1], g1 = times[1] - times[0];
        const double step = pow(h, 3.0) / 12.0;
        factor = step / (step + h * (h + g0) * (h + g0 + g1) / 6.0);
    }
    double *restrict sq = R->squares;
    double fields[3], jump;
    if (k == 2)
        ra_differences(n, s, states, weight, factor, 2, R->massless_end, sq, fields, &jump);
    else
        ra_differences(n, s, states, weight, factor, 3, R->massless_end, sq, fields, &jump);
    if (R->massless_end)
        sq[2 * (size_t)n - 1] = 0.0;
    double e_p = 0.0;
    for (int i = 0; i < k; i++)
        e_p += states[i][3 * (size_t)n] * weight[i];
    e_p = measured ? (p - e_p) * factor : 0.0;
    ra_grow(R, fields, jump, p, grown);
    return ra_norm(R, sq, e_p, grown);
}

/* ErrorNorm.__call__ of the error's squares sq (3n) and its p entry e_p, with the maxima grown
 * by y (grown). */
static double ra_norm(const ra_run *R, const double *sq, double e_p, const double grown[4])
{
    const int n = R->n;
    double scale[4] = {grown[0], grown[1], grown[2], grown[3]};
    if (R->b > 0.0)
        scale[1] = ra_pymax(scale[1], R->dt0 * scale[3] / sqrt(R->b));
    double parts[4];
    for (int c = 0; c < 3; c++)
        parts[c] = sqrt(ra_pairwise(sq + (size_t)c * n, n) / n);
    parts[3] = R->force ? fabs(e_p) : 0.0;
    double largest = 0.0;
    for (int c = 0; c < 4; c++) {
        const double ratio = scale[c] > 0.0 ? parts[c] / (R->tolerance * scale[c])
                                            : (parts[c] == 0.0 ? 0.0 : INFINITY);
        if (c == 0 || ratio > largest)
            largest = ratio;
    }
    return largest;
}

/* The maxima of the norm with y = [s; p] counted (ErrorNorm.grown). */
static inline void ra_grown(const ra_run *R, const double *s, double p, double grown[4])
{
    double fields[3], jump;
    ra_differences(R->n, s, NULL, NULL, 0.0, 0, R->massless_end, NULL, fields, &jump);
    ra_grow(R, fields, jump, p, grown);
}

/* AdaptiveStepper._halves' error: ErrorNorm of (y - whole) / (2^order - 1), y = [s; p] the end
 * of the second half and whole the end of the step. */
static double ra_halves_error(ra_run *R, const double *s, double p)
{
    const int n = R->n;
    const double divisor = pow(2.0, R->order) - 1.0, *whole = R->whole;
    double *restrict sq = R->squares;
    for (int i = 0; i < 3 * n; i++) {
        const double e = (s[i] - whole[i]) / divisor;
        sq[i] = e * e;
    }
    if (R->massless_end)
        sq[2 * (size_t)n - 1] = 0.0;
    double grown[4];
    ra_grown(R, s, p, grown);
    return ra_norm(R, sq, (p - whole[3 * (size_t)n]) / divisor, grown);
}

/* The raw history row of the home state (History.record), and its readings: the energy's sums
 * in PETSc's order, (2w + E s) row by row in column order, then its dot with s. */
static void ra_row(ra_run *R, double *row)
{
    const int n = R->n, N = 3 * n;
    const double *s = R->values, *E = R->e_band, *w = R->two_w;
    double energy = ((w[0] + E[1] * s[0]) + E[2] * s[1]) * s[0];
    for (int i = 1; i < N - 1; i++) {
        const double *e = E + 3 * (size_t)i;
        energy += (((w[i] + e[0] * s[i - 1]) + e[1] * s[i]) + e[2] * s[i + 1]) * s[i];
    }
    if (N > 1) {
        const double *e = E + 3 * (size_t)(N - 1);
        energy += ((w[N - 1] + e[0] * s[N - 2]) + e[1] * s[N - 1]) * s[N - 1];
    }
    row[RAW_N] = (double)R->step;
    row[RAW_ITERATIONS] = (double)R->iterations;
    row[RAW_U_1] = s[R->u_1];
    row[RAW_D_1] = s[R->du_1];
    row[RAW_U_HALF] = R->half_wi * s[R->half_i] + R->half_wj * s[R->half_j];
    row[RAW_BULK_ENERGY] = 0.5 * energy;
    row[RAW_PRESSURE] = R->pressure;
    if (R->readings.count) {
        const double *const part[3] = {s, s + n, s + 2 * (size_t)n};
        rr_read(&R->readings, n, part, 1, row + RAW_SLOTS);
    }
}

static inline int ra_finite_row(const double *row)
{
    return isfinite(row[RAW_U_1]) && isfinite(row[RAW_PRESSURE]) && isfinite(row[RAW_D_1]) &&
           isfinite(row[RAW_U_HALF]) && isfinite(row[RAW_BULK_ENERGY]);
}

/* AdaptiveStepper.y's last entry: the contact force measured of the home state. */
static inline double ra_measured(const ra_run *R)
{
    return R->end_force ? rc_force(&R->obstacle, R->values[3 * (size_t)R->n - 1]) : R->pressure;
}

/* The problem of a step h at hand: the table's, or the pool's (counted as used); else NULL. */
static void *ra_problem(ra_run *R, double h)
{
    for (int k = 0; k < R->sizes; k++)
        if (R->size_h[k] == h)
            return R->size_problem[k];
    for (int k = 0; k < R->pool; k++)
        if (R->pool_h[k] == h) {
            R->pool_used[k] = ++R->uses;
            return R->pool_problem[k];
        }
    return NULL;
}

/* Back to the start of the step tried. */
static inline void ra_restore(ra_run *R, long step, int iterations, double pressure)
{
    const int n = R->n;
    memcpy(R->values, R->start, sizeof(double) * 3 * (size_t)n);
    memcpy(R->u_prev, R->start_u_prev, sizeof(double) * (size_t)n);
    R->step = step;
    R->iterations = iterations;
    R->pressure = pressure;
}

static inline void ra_scale(double *D, int n, double factor)
{
    for (int i = 0; i < n; i++)
        D[i] *= factor;
}

#endif

#ifdef RA_NAME
/* Home from the start of the step (R->start, ...) one step h on by `problem`, D scaled to the
 * step's and back (AdaptiveStepper._take): 1, or 0 where the method did not solve it. */
static int ra_take(ra_run *R, double h, void *problem, long step, int iterations,
                   double pressure)
{
    const int n = R->n;
    double *D = R->values + n;
    ra_restore(R, step, iterations, pressure);
    if (h != R->dt0)
        ra_scale(D, n, h / R->dt0);
    if (!(RA_STEP(problem, R->values, R->u_prev, step, R->scratch_row, &R->pressure,
                  &R->iterations)))
        return 0;
    if (h != R->dt0)
        ra_scale(D, n, R->dt0 / h);
    R->step = step + 1;
    return 1;
}

/* The problem of a step h: at hand (ra_problem), or formed here in the pool's least recently
 * used slot; NULL where there is no pool (RA_NEED: the stepper makes it) or the size cannot be
 * formed (the stepper makes it again, and says why). A size's problem is the same wherever it is
 * formed, so the pool's size changes no decision; a problem found or formed here is the most
 * recently used, so with two slots or more a second one never evicts the first. */
static void *ra_size(ra_run *R, double h)
{
    void *problem = ra_problem(R, h);
    if (problem != NULL || R->family == NULL || R->pool < 2)
        return problem;
    int slot = 0;
    for (int k = 1; k < R->pool; k++)
        if (R->pool_used[k] < R->pool_used[slot])
            slot = k;
    problem = R->pool_problem[slot];
    R->pool_h[slot] = 0.0;
    R->pool_used[slot] = 0;
    memcpy(problem, R->template_problem, (size_t)R->problem_bytes);
    if (RA_FORM(R->family, R->dt0 / h, problem, R->pool_memory[slot]))
        return NULL;
    R->pool_h[slot] = h;
    R->pool_used[slot] = ++R->uses;
    R->formed++;
    return problem;
}

/* The problem of a step h: at hand (ra_problem), or formed in the scratch place `slot` (an
 * event's tries, each size tried once: the pool's sizes stay); NULL where it cannot be formed. */
static void *ra_sized(ra_run *R, double h, int slot)
{
    void *problem = ra_problem(R, h);
    if (problem != NULL)
        return problem;
    memcpy(R->scratch[slot], R->template_problem, (size_t)R->problem_bytes);
    if (RA_FORM(R->family, R->dt0 / h, R->scratch[slot], R->scratch_memory[slot]))
        return NULL;
    return R->scratch[slot];
}

/* A side's tries: the newest (c, f) in, the oldest out. */
static inline void ra_tried(double pairs[4], int *count, double c, double f)
{
    pairs[0] = pairs[2];
    pairs[1] = pairs[3];
    pairs[2] = c;
    pairs[3] = f;
    (*count)++;
}

/* events.locate (rodfem/solver/adaptive/events.py): the step's size where contact changes, to
 * a bracket event_width wide, from the start of the step (f_a its contact) and the step h tried
 * (problem_b, home at its end): the first try where the tangent at the start meets zero (its
 * slope the end's velocity, events.tangent), then the secant through the last two tries on the
 * latest's side, each tried event_past beyond its root where the bracket's changed end is the
 * farther, else a quarter bracket short of it; else the Illinois method's point (bisection after
 * 60 tries). Home is left at the far end, contact changed. Returns the size, or 0 where a try
 * could not be formed or solved. */
static double ra_locate(ra_run *R, double h, void *problem_b, double fa, int before,
                        long step, int iterations, double pressure)
{
    const int n = R->n;
    const double width = R->event_width;
    double a = 0.0, b = h, fb = ra_contact(R, R->values[3 * (size_t)n - 1], R->pressure);
    int side = 0, at_b = 1, tries = 0;
    double near[4] = {0.0, 0.0, 0.0, fa}, far[4] = {0.0, 0.0, h, fb};
    int near_count = 1, far_count = 1;
    while (b - a > width) {
        tries++;
        double c = 0.0;
        int guessed = 0;
        if (tries == 1) {
            if (!R->massless_end && !(R->rigid && before)) {
                const double slope = R->start[2 * (size_t)n - 1] / R->dt0;
                if (fa * slope < 0.0) {
                    c = -fa / slope;
                    guessed = 1;
                }
            }
        } else if (tries < 60) {  /* events.secant, (c1, f1, c2, f2) */
            const double *pairs = side == -1 ? far : near;
            if ((side == -1 ? far_count : near_count) >= 2 && pairs[3] != pairs[1]) {
                c = pairs[2] - pairs[3] * (pairs[2] - pairs[0]) / (pairs[3] - pairs[1]);
                guessed = 1;
            }
        }
        if (guessed && a < c && c < b) {  /* just past the root, or a quarter bracket short */
            c = b - c > c - a ? c + R->event_past : c - 0.25 * width;
            c = ra_pymin(ra_pymax(c, a + R->event_past), b - 0.25 * width);
        } else {
            c = fb != fa && tries < 60 ? b - fb * (b - a) / (fb - fa) : 0.5 * (a + b);
            c = ra_pymin(ra_pymax(c, a + 0.25 * width), b - 0.25 * width);
        }
        void *problem = ra_sized(R, c, problem_b == R->scratch[0] ? 1 : 0);
        if (problem == NULL || !ra_take(R, c, problem, step, iterations, pressure))
            return 0.0;
        const double fc = ra_contact(R, R->values[3 * (size_t)n - 1], R->pressure);
        if ((fc > 0.0) != before) {
            b = c;
            fb = fc;
            at_b = 1;
            problem_b = problem;
            ra_tried(far, &far_count, c, fc);
            if (side == -1)
                fa *= 0.5;
            side = -1;
        } else {
            a = c;
            fa = fc;
            at_b = 0;
            ra_tried(near, &near_count, c, fc);
            if (side == 1)
                fb *= 0.5;
            side = 1;
        }
    }
    if (!at_b && !ra_take(R, b, problem_b, step, iterations, pressure))
        return 0.0;
    return b;
}

/* ra_take, then whether contact is as it was (`before`) at the step's end: 1 if it is, -1 if
 * it changed, 0 where the method did not solve the step. */
static inline int ra_take_within(ra_run *R, double h, void *problem, long step, int iterations,
                                 double pressure, int before)
{
    if (!ra_take(R, h, problem, step, iterations, pressure))
        return 0;
    return (ra_contact(R, R->values[3 * (size_t)R->n - 1], R->pressure) > 0.0) == before ? 1
                                                                                         : -1;
}

/* Home back at the start of a restart's step while the second half ran from the first. */
static void ra_restore_held(ra_run *R, long step, int iterations, double pressure)
{
    const size_t n = (size_t)R->n;
    memcpy(R->start, R->held, sizeof(double) * 3 * n);
    memcpy(R->start_u_prev, R->held + 3 * n, sizeof(double) * n);
    ra_restore(R, step, iterations, pressure);
}

/* The estimate's restart from the home state (AdaptiveStepper._attempt with fewer than
 * order + 1 states since the start or the last event, and _halves): the step h, then h as two
 * halves, the error their difference from it. Returns -1 after accepting both halves, -2 after
 * rejecting the step (R->h the next size), RA_PAUSE after accepting them where a regular step
 * would pause there; or, with home at the start, RA_NEED (a size to make: the step's, or its
 * half's on the ladder), RA_RESTART (the stepper takes it: the module's comment says when),
 * RA_PAUSE (room for fewer than two rows after some written) or RA_TOO_SMALL. */
static long ra_restart(ra_run *R, long max_steps)
{
    const int n = R->n, size = 3 * n + 1, places = R->order + 1;
    const size_t N = 3 * (size_t)n;
    if (R->written + 2 > max_steps || R->written + 2 > R->room)
        return R->written ? RA_PAUSE : RA_RESTART;
    const int before = ra_contact(R, R->values[N - 1], R->pressure) > 0.0;
    const double h = ra_proposal(R, before), half = 0.5 * h;
    void *problem = ra_size(R, h), *problem_half = ra_size(R, half);
    if (problem == NULL || problem_half == NULL) {
        if (problem == NULL || ra_rung(R->dt0, half) == half) {
            R->wanted = problem == NULL ? h : half;
            return RA_NEED;
        }
        return RA_RESTART;  /* a half off the ladder: the stepper's size of one step */
    }
    const double t0 = R->t;
    const double t1 = ra_after(R, t0, half);
    if (R->interval > 0.0 && floor(t1 / R->interval) > R->frame)
        return RA_RESTART;  /* the fields are saved at the first half's state */
    const long step = R->step;
    const int iterations = R->iterations;
    const double pressure = R->pressure;
    memcpy(R->start, R->values, sizeof(double) * N);
    memcpy(R->start_u_prev, R->u_prev, sizeof(double) * (size_t)n);
    /* the step (one that meets an event is the stepper's to locate and accept) */
    int within = ra_take_within(R, h, problem, step, iterations, pressure, before);
    if (within <= 0) {
        ra_restore(R, step, iterations, pressure);
        return RA_RESTART;
    }
    /* then its first half from the same start: a half that meets an event rejects the step as
     * an infinite error would (_halves) */
    memcpy(R->whole, R->values, sizeof(double) * N);
    R->whole[N] = ra_measured(R);
    within = ra_take_within(R, half, problem_half, step, iterations, pressure, before);
    if (within <= 0) {
        ra_restore(R, step, iterations, pressure);
        return within ? ra_reject(R, h, INFINITY) : RA_RESTART;
    }
    double *row1 = R->rows + (size_t)R->written * R->width;
    ra_row(R, row1);
    if (!ra_finite_row(row1)) {
        ra_restore(R, step, iterations, pressure);
        return RA_RESTART;
    }
    const int slot1 = (R->head + R->count) % places;  /* free: count < places */
    double *y1 = R->past + (size_t)slot1 * size;
    memcpy(y1, R->values, sizeof(double) * N);
    y1[N] = ra_measured(R);
    /* the second half, from the first */
    const long step1 = R->step;
    const int iterations1 = R->iterations;
    const double pressure1 = R->pressure;
    memcpy(R->held, R->start, sizeof(double) * N);
    memcpy(R->held + N, R->start_u_prev, sizeof(double) * (size_t)n);
    memcpy(R->start, R->values, sizeof(double) * N);
    memcpy(R->start_u_prev, R->u_prev, sizeof(double) * (size_t)n);
    within = ra_take_within(R, half, problem_half, step1, iterations1, pressure1, before);
    if (within <= 0) {
        ra_restore_held(R, step, iterations, pressure);
        return within ? ra_reject(R, h, INFINITY) : RA_RESTART;
    }
    const double p2 = ra_measured(R);
    double error = ra_halves_error(R, R->values, p2);
    if (!(error <= 1.0)) {
        ra_restore_held(R, step, iterations, pressure);
        return ra_reject(R, h, error);
    }
    /* Controller.accepted of the second half, then AdaptiveStepper._accept of both */
    const double following = ra_accepted(R, half, error);
    double grown[4];
    ra_grown(R, y1, y1[N], grown);
    for (int m = 0; m < 4; m++)
        R->maxima[m] = grown[m];
    R->t = t1;
    R->past_t[ra_place(R)] = t1;  /* slot1, the first free place */
    double *clock = R->clock + 3 * (size_t)R->written;
    clock[0] = t1;
    clock[1] = half;
    clock[2] = 0.0;
    R->written++;
    ra_grown(R, R->values, p2, grown);
    for (int m = 0; m < 4; m++)
        R->maxima[m] = grown[m];
    R->t = ra_after(R, t1, half);
    const int at = ra_place(R);
    double *kept = R->past + (size_t)at * size;
    memcpy(kept, R->values, sizeof(double) * N);
    kept[N] = p2;
    R->past_t[at] = R->t;
    R->h = following;
    double *row = R->rows + (size_t)R->written * R->width;
    ra_row(R, row);
    clock = R->clock + 3 * (size_t)R->written;
    clock[0] = R->t;
    clock[1] = half;
    clock[2] = 0.0;
    R->written++;
    if (!ra_finite_row(row))
        return RA_PAUSE;
    if (R->interval > 0.0 && floor(R->t / R->interval) > R->frame)
        return RA_PAUSE;
    return -1;
}

/* Accepted steps until one of the RA_ codes happens (at most max_steps, and R->room rows). */
long RA_NAME(ra_run *R, long max_steps)
{
    const int n = R->n, size = 3 * n + 1;
    double *D = R->values + n;
    R->written = 0;
    for (;;) {
        if (!(R->t < R->end))
            return RA_END;
        if (R->written >= max_steps || R->written >= R->room)
            return RA_PAUSE;
        if (R->count <= R->order) {
            const long done = ra_restart(R, max_steps);
            if (done == -1 || done == -2)
                continue;
            return done;
        }
        const int before = ra_contact(R, R->values[3 * (size_t)n - 1], R->pressure) > 0.0;
        const double h = ra_proposal(R, before);
        void *problem = ra_size(R, h);
        if (problem == NULL) {
            R->wanted = h;
            return RA_NEED;
        }
        const long step = R->step;
        const int iterations = R->iterations;
        const double pressure = R->pressure;
        memcpy(R->start, R->values, sizeof(double) * 3 * (size_t)n);
        memcpy(R->start_u_prev, R->u_prev, sizeof(double) * (size_t)n);
        if (h != R->dt0)
            ra_scale(D, n, h / R->dt0);
        if (!(RA_STEP(problem, R->values, R->u_prev, step, R->scratch_row, &R->pressure,
                      &R->iterations))) {
            ra_restore(R, step, iterations, pressure);
            return RA_FAILED;
        }
        if (h != R->dt0)
            ra_scale(D, n, R->dt0 / h);
        R->step = step + 1;
        double h_taken = h;
        const int event =
            (ra_contact(R, R->values[3 * (size_t)n - 1], R->pressure) > 0.0) != before;
        if (event) {
            if (R->family == NULL) {
                ra_restore(R, step, iterations, pressure);
                return RA_EVENT;
            }
            const double f0 = ra_contact(R, R->start[3 * (size_t)n - 1], pressure);
            h_taken = ra_locate(R, h, problem, f0, before, step, iterations, pressure);
            if (h_taken == 0.0) {  /* the stepper takes it again, and says why it fails */
                ra_restore(R, step, iterations, pressure);
                return RA_FAILED;
            }
        }
        double grown[4];
        const double measured = ra_measured(R);
        /* a jump of p at the event is no error (AdaptiveStepper.jumps) */
        double error = ra_predicted(R, h_taken, R->values, measured, !(event && R->jumps), grown);
        if (!(error <= 1.0)) {
            ra_restore(R, step, iterations, pressure);
            const long code = ra_reject(R, h_taken, error);
            if (code != -2)
                return code;
            continue;
        }
        /* Controller.accepted, then AdaptiveStepper._accept */
        const double following = ra_accepted(R, h_taken, error);
        R->t = ra_after(R, R->t, h_taken);
        for (int m = 0; m < 4; m++)
            R->maxima[m] = grown[m];
        int at;
        if (event) {  /* the estimate starts again from this state (or after it, where p jumps) */
            R->head = at = 0;
            R->count = R->jumps ? 0 : 1;
            R->events++;
        } else {
            at = ra_place(R);
        }
        double *kept = R->past + (size_t)at * size;
        memcpy(kept, R->values, sizeof(double) * 3 * (size_t)n);
        kept[3 * (size_t)n] = measured;
        R->past_t[at] = R->t;
        R->h = following;
        double *row = R->rows + (size_t)R->written * R->width;
        ra_row(R, row);
        double *clock = R->clock + 3 * (size_t)R->written;
        clock[0] = R->t;
        clock[1] = h_taken;
        clock[2] = event ? 1.0 : 0.0;
        R->written++;
        if (!ra_finite_row(row))
            return RA_PAUSE;
        if (R->interval > 0.0 && floor(R->t / R->interval) > R->frame)
            return RA_PAUSE;
    }
}

#endif
