/*
 * exchange.h -- the heat exchange at x = 1 for rodfem's compiled loops (picard.c takes the law and
 * its place, direct.c the step's equation too): rodfem/model/exchange/ (pressure.py, gap.py) and
 * the direct step's scalar equation,
 * rodfem/solver/methods/exchange_step.py, in C, formula for formula, so that a compiled step
 * takes the same branches as the Python one. A new law is a new case here beside its Python
 * module; rodfem/solver/compiled/loop.py's check_library checks the codes below against the
 * Python laws' ``code``. Needs contact.h.
 */
#ifndef RODFEM_EXCHANGE_H
#define RODFEM_EXCHANGE_H

#include <math.h>

#include "contact.h"

/* cdef begin: the declarations cffi reads */
enum { RX_CONSTANT = 0, RX_PRESSURE = 1, RX_GAP = 2 };

typedef struct {
    int law;              /* RX_CONSTANT (no flux: contact.h's step alone), RX_PRESSURE, RX_GAP */
    double k1, exponent;  /* q = k1 p^exponent (pressure) */
    double gap, length;   /* q = k1 exp(min(y - gap, 0)/length) (gap) */
    /* the step's scalars (ExchangeStep): the responses alpha = q_h,U(1), beta = q_c,Theta(1),
     * gamma = q_h,Theta(1), the time scheme's weight and the offset of theta(1) - theta_O */
    double alpha, beta, gamma, weight, offset;
} rx_exchange;
/* cdef end */

/* q at the end displacement y (the time scheme's place) under the force p: PressureLaw.extra,
 * GapLaw.extra. */
static inline double rx_extra(const rx_exchange *X, double y, double p)
{
    if (X->law == RX_PRESSURE)
        return p > 0.0 ? X->k1 * pow(p, X->exponent) : 0.0;
    const double d = y - X->gap;
    return X->k1 * exp((0.0 < d ? 0.0 : d) / X->length);
}

/* Bounds of dq/dy and dq/dp over the bracket (ExchangeLaw.extra_slope_bounds, GapLaw's). */
static inline void rx_slope_bounds(const rx_exchange *X, double y_hi, double p_lo, double p_hi,
                                   double *L_y, double *L_p)
{
    if (X->law == RX_GAP) {
        *L_y = rx_extra(X, y_hi, p_hi) / X->length;
        *L_p = 0.0;
        return;
    }
    /* PressureLaw.extra_slopes at p_lo and p_hi, the larger */
    const double m = X->exponent, k1 = X->k1;
    double slope[2];
    const double ps[2] = {p_lo, p_hi};
    for (int i = 0; i < 2; i++) {
        const double p = ps[i];
        if (p > 0.0)
            slope[i] = k1 * m * pow(p, m - 1.0);
        else if (m == 1.0)
            slope[i] = k1;
        else
            slope[i] = m > 1.0 || k1 == 0.0 ? 0.0 : INFINITY;
    }
    *L_y = 0.0;
    *L_p = slope[0] > slope[1] ? slope[0] : slope[1];
}

/* TimeScheme.exchange_place: y (paper), c + w (y - c) (Crank-Nicolson). */
static inline double rx_place(const rx_exchange *X, double y, double c)
{
    return X->weight == 1.0 ? y : c + X->weight * (y - c);
}

/* ExchangeStep.at: p, y and q of the free reach t; returns phi. */
static inline double rx_at(const rx_exchange *X, const rc_obstacle *O, double w, double t,
                           double c, double T0, double *p, double *y, double *q)
{
    *p = rc_contact_needed(O, t, c) ? rc_solve(O, t, w, c) : 0.0;
    *y = t - w * *p;
    *q = rx_extra(X, rx_place(X, *y, c), *p);
    if (*q == 0.0)
        return 0.0;
    return *q * ((T0 + X->weight * X->beta * *p) / (1.0 - X->weight * X->gamma * *q));
}

static inline double rx_G(const rx_exchange *X, const rc_obstacle *O, double w, double t,
                          double s, double c, double T0)
{
    double p, y, q;
    return t - s - X->alpha * rx_at(X, O, w, t, c, T0, &p, &y, &q);
}

/* exchange_step.py's bracketed_root for G. */
static inline double rx_root(const rx_exchange *X, const rc_obstacle *O, double w, double s,
                             double c, double T0, double lo, double hi, double f_lo, double f_hi)
{
    int side = 0;
    double F_lo = f_lo, F_hi = f_hi;
    for (int it = 0; it < 4000; it++) {
        double t = lo - f_lo * ((hi - lo) / (f_hi - f_lo));
        if (!(lo < t && t < hi))
            t = lo + 0.5 * (hi - lo);
        if (!(lo < t && t < hi))
            break;
        const double f = rx_G(X, O, w, t, s, c, T0);
        if (f == 0.0)
            return t;
        if (f > 0.0) {
            hi = t;
            f_hi = F_hi = f;
            if (side == 1)
                f_lo *= 0.5;
            side = 1;
        } else {
            lo = t;
            f_lo = F_lo = f;
            if (side == -1)
                f_hi *= 0.5;
            side = -1;
        }
    }
    return fabs(F_lo) < fabs(F_hi) ? lo : hi;
}

/* ExchangeStep.force_slope. */
static inline double rx_force_slope(const rc_obstacle *O, double y_hi, double c)
{
    if (O->law == RC_RIGID)
        return INFINITY;
    return rc_slope(O, O->gradient && c > y_hi ? c : y_hi);
}

/* ExchangeStep.unique: 1 if G is shown to have one root in [lo, hi]. */
static inline int rx_unique(const rx_exchange *X, const rc_obstacle *O, double w, double lo,
                            double hi, double c, double T0)
{
    double p_lo, y_lo, q_lo, p_hi, y_hi, q_hi;
    rx_at(X, O, w, lo, c, T0, &p_lo, &y_lo, &q_lo);
    rx_at(X, O, w, hi, c, T0, &p_hi, &y_hi, &q_hi);
    const double alpha = X->alpha, beta = X->beta, weight = X->weight;
    const double N_lo = T0 + weight * beta * p_lo, N_hi = T0 + weight * beta * p_hi;
    if (N_lo >= 0.0 && N_hi >= 0.0 && alpha <= 0.0 && beta >= 0.0)
        return 1;
    if (N_lo <= 0.0 && N_hi <= 0.0 && alpha >= 0.0 && beta <= 0.0)
        return 1;
    double L_y, L_p;
    rx_slope_bounds(X, rx_place(X, y_hi, c), p_lo, p_hi, &L_y, &L_p);
    const double g_hi = q_hi / (1.0 - weight * X->gamma * q_hi);
    const double N_max = fabs(N_lo) > fabs(N_hi) ? fabs(N_lo) : fabs(N_hi);
    const double c_y = fabs(alpha) * N_max * weight * L_y;
    const double c_p = fabs(alpha) * (N_max * L_p + g_hi * weight * fabs(beta));
    double margin = 1.0 - c_y;
    if (!(w - c_p > 0.0))
        margin += (w - c_p) * rx_force_slope(O, y_hi, c);
    return margin > 0.0;
}

/* ExchangeStep.solve: the step's p and phi (*phi) from s = c + z_U(1), c = U^(n-1)(1) and T0.
 * Returns 0, or 1 where the root is not shown to be unique (the step is not taken). */
static inline int rx_solve(const rx_exchange *X, const rc_obstacle *O, double w, double s,
                           double c, double T0, double *p, double *phi)
{
    double y, q;
    const double f = rx_G(X, O, w, s, s, c, T0);
    if (f == 0.0) {
        *phi = rx_at(X, O, w, s, c, T0, p, &y, &q);
        return 0;
    }
    const double direction = f < 0.0 ? 1.0 : -1.0;
    double width = fabs(f), near = s, f_near = f, far = s, f_far = NAN;
    int found = 0;
    for (int it = 0; it < 2100; it++) {
        far = s + direction * width;
        f_far = rx_G(X, O, w, far, s, c, T0);
        if (!(isfinite(far) && isfinite(f_far)))
            break;
        if (direction > 0.0 ? f_far >= 0.0 : f_far <= 0.0) {
            found = 1;
            break;
        }
        near = far;
        f_near = f_far;
        width = 2.0 * width;
    }
    if (!found)
        return 1;
    double lo = near, hi = far, f_lo = f_near, f_hi = f_far;
    if (direction < 0.0) {
        lo = far;
        hi = near;
        f_lo = f_far;
        f_hi = f_near;
    }
    if (!rx_unique(X, O, w, lo, hi, c, T0))
        return 1;
    const double t = f_hi == 0.0   ? hi
                     : f_lo == 0.0 ? lo
                                   : rx_root(X, O, w, s, c, T0, lo, hi, f_lo, f_hi);
    *phi = rx_at(X, O, w, t, c, T0, p, &y, &q);
    return 0;
}

#endif
