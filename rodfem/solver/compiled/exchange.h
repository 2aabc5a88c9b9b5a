/*
 * exchange.h -- the heat exchange at x = 1 for rodfem's compiled loops: rodfem/model/exchange/ in
 * C, formula for formula (law.py's constant law, pressure.py, gap.py), and the time scheme's place
 * of the end (rodfem/solver/time_schemes.py, TimeScheme.exchange_place). A new law is a new case
 * here beside its Python module; rodfem/solver/compiled/loop.py checks that the codes below are
 * its EXCHANGE_CODES.
 *
 * h = k + q at x = 1, k in the loops' operators; a variable law's q(y, p) adds the flux
 * q (Theta(1) + offset) to the heat row of x = 1 (forms/copetti.py, exchange).
 */
#ifndef RODFEM_EXCHANGE_H
#define RODFEM_EXCHANGE_H

#include <math.h>

/* cdef begin: the declarations cffi reads */
enum { RX_CONSTANT = 0, RX_PRESSURE = 1, RX_GAP = 2 };

typedef struct {
    int law;          /* RX_CONSTANT (q = 0), RX_PRESSURE or RX_GAP */
    double k1;        /* the exchange the contact adds (pressure: at unit pressure) */
    double exponent;  /* m of the pressure law */
    double gap;       /* the obstacle's gap g (gap law) */
    double length;    /* the gap law's length */
    double weight;    /* the time scheme's weight: where in the step the end is taken */
    double offset;    /* theta(1) - theta_O = Theta(1) + offset */
} rx_exchange;
/* cdef end */

/* q at the end's displacement y under the contact force p: ExchangeLaw.extra. */
static inline double rx_extra(const rx_exchange *X, double y, double p)
{
    if (X->law == RX_PRESSURE)
        return p > 0.0 ? X->k1 * pow(p, X->exponent) : 0.0;
    if (X->law == RX_GAP) {
        const double d = y - X->gap;
        return X->k1 * exp((0.0 < d ? 0.0 : d) / X->length);  /* Python's min(d, 0.0) */
    }
    return 0.0;
}

/* TimeScheme.exchange_place: U^n(1) = y (weight 1), else c + weight (y - c), c = U^(n-1)(1). */
static inline double rx_place(const rx_exchange *X, double y, double c)
{
    return X->weight == 1.0 ? y : c + X->weight * (y - c);
}

/* The step's q for U^n(1) = y, U^(n-1)(1) = c and the contact force p. */
static inline double rx_step_extra(const rx_exchange *X, double y, double c, double p)
{
    return rx_extra(X, rx_place(X, y, c), p);
}

#endif
