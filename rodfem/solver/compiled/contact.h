/*
 * contact.h -- the obstacle at x = 1 for rodfem's compiled loops: rodfem/model/contact/ in C,
 * formula for formula (linear.py, power.py, rigid.py, and law.py's monotone_root), so that a
 * compiled step takes the same branches as the Python one. A new law is a new case here beside
 * its Python module; rodfem/solver/compiled/build.py checks that the codes below are the Python
 * laws' ``code``.
 */
#ifndef RODFEM_CONTACT_H
#define RODFEM_CONTACT_H

#include <math.h>

/* cdef begin: the declarations cffi reads */
enum { RC_LINEAR = 0, RC_POWER = 1, RC_RIGID = 2 };

typedef struct {
    int law;          /* RC_LINEAR, RC_POWER or RC_RIGID */
    int gradient;     /* 1: Crank-Nicolson's discrete gradient from U^(n-1)(1); 0: the force at
                         the new step */
    double gap, epsilon, exponent;
} rc_obstacle;

/* The end x = 1 (rodfem/solver/methods/massless.py): with its mass (RC_END_MASS), without it
 * (RC_END_MASSLESS: D^n(1) = U^n(1) - U^(n-1)(1), no velocity of its own), or without it and
 * eliminated (RC_END_ELIMINATED, Crank-Nicolson with zeta = 0): the contact law, rc_obstacle,
 * is then the obstacle in series with the last cell, taken at the end's free position
 *     y = theta[0] Theta(n-2) + theta[1] Theta(n-1) + u[0] U(n-2) + u[1] U(n-1) + constant,
 * and after the step the end is settled (rc_end_settle). */
enum { RC_END_MASS = 0, RC_END_MASSLESS = 1, RC_END_ELIMINATED = 2 };

typedef struct {
    int kind;             /* RC_END_MASS, RC_END_MASSLESS or RC_END_ELIMINATED */
    double theta[2], u[2], constant;  /* y's row (nodes n-2, n-1) and constant */
    double epsilon;       /* the obstacle's own compliance (0: rigid) */
} rc_end;
/* cdef end */

/* Python's max(x, 0.0): x unless 0.0 > x (NaN stays NaN). */
static inline double rc_pmax0(double x) { return 0.0 > x ? 0.0 : x; }

/* phi, phi' and phi'' at y (0 at y <= g). */
static inline double rc_energy(const rc_obstacle *O, double y)
{
    const double d = y - O->gap;
    if (O->law == RC_POWER)
        return d > 0.0 ? pow(d, O->exponent + 1.0) / ((O->exponent + 1.0) * O->epsilon) : 0.0;
    const double p = rc_pmax0(d);
    return 0.5 * (p * p) / O->epsilon;
}

static inline double rc_force(const rc_obstacle *O, double y)
{
    const double d = y - O->gap;
    if (O->law == RC_POWER)
        return d > 0.0 ? pow(d, O->exponent) / O->epsilon : 0.0;
    return rc_pmax0(d) / O->epsilon;
}

static inline double rc_slope(const rc_obstacle *O, double y)
{
    const double d = y - O->gap;
    if (O->law == RC_POWER)
        return d > 0.0 ? O->exponent * pow(d, O->exponent - 1.0) / O->epsilon : 0.0;
    return d > 0.0 ? 1.0 / O->epsilon : 0.0;
}

/* (phi(y) - phi(c))/(y - c), phi'(c) where y = c: LinearLaw.gradient, PowerLaw.gradient. */
static inline double rc_gradient(const rc_obstacle *O, double y, double c)
{
    const double dy = y - O->gap, dc = c - O->gap;
    if (O->law == RC_LINEAR) {
        if (dy <= 0.0 && dc <= 0.0)
            return 0.0;
        if (dy > 0.0 && dc > 0.0)
            return (dy + dc) / (2.0 * O->epsilon);
        if (y == c)
            return rc_pmax0(dy) / O->epsilon;
        const double py = rc_pmax0(dy), pc = rc_pmax0(dc);
        return (py * py - pc * pc) / (2.0 * O->epsilon * (y - c));
    }
    if (dy > 0.0 && dc > 0.0 && y != c && fabs(y - c) <= 0.5 * dc) {  /* PowerLaw's CLOSE */
        const double m1 = O->exponent + 1.0, r = (y - c) / dc;
        return pow(dc, O->exponent) / O->epsilon * expm1(m1 * log1p(r)) / (m1 * r);
    }
    if (y == c)
        return rc_force(O, c);
    if (y <= O->gap && c <= O->gap)
        return 0.0;
    return (rc_energy(O, y) - rc_energy(O, c)) / (y - c);
}

static inline double rc_gradient_slope(const rc_obstacle *O, double y, double c)
{
    if (y == c)
        return 0.5 * rc_slope(O, y);
    return (rc_force(O, y) - rc_gradient(O, y, c)) / (y - c);
}

/* The contact force of the step for U^n(1) = y, U^(n-1)(1) = c. */
static inline double rc_contact_force(const rc_obstacle *O, double y, double c)
{
    return O->gradient ? rc_gradient(O, y, c) : rc_force(O, y);
}

/* Whether a step whose free end would reach s from c can meet the obstacle at all. */
static inline int rc_contact_needed(const rc_obstacle *O, double s, double c)
{
    return s > O->gap || (O->gradient && c > O->gap);
}

/* law.py's monotone_root for F(y) = y + w p(y) - s, p = rc_contact_force. */
static inline double rc_monotone_root(const rc_obstacle *O, double s, double w, double c,
                                      double lo, double hi)
{
    double y = hi, f_lo = -INFINITY, f_hi = INFINITY;
    for (int it = 0; it < 4000; it++) {
        const double f = y + w * rc_contact_force(O, y, c) - s;
        if (f == 0.0)
            return y;
        if (f > 0.0) {
            hi = y;
            f_hi = f;
        } else {
            lo = y;
            f_lo = f;
        }
        const double d = 1.0 + w * (O->gradient ? rc_gradient_slope(O, y, c) : rc_slope(O, y));
        double step = d > 0.0 ? y - f / d : NAN;
        if (!(lo < step && step < hi))
            step = lo + 0.5 * (hi - lo);
        if (!(lo < step && step < hi))
            break;
        y = step;
    }
    return fabs(f_lo) < fabs(f_hi) ? lo : hi;
}

/* linear.py's positive_root: the root q >= 0 of A q^2 + B q + C = 0, A > 0, C <= 0. */
static inline double rc_positive_root(double A, double B, double C)
{
    double disc = sqrt(B * B - 4.0 * A * C);
    return B >= 0.0 ? -2.0 * C / (B + disc) : (-B + disc) / (2.0 * A);
}

/* TimeScheme.contact_solve: the contact force p with y + w p(y) = s, y = U^n(1), c = U^(n-1)(1);
 * then U^n(1) = s - w p. Call where rc_contact_needed. */
static inline double rc_solve(const rc_obstacle *O, double s, double w, double c)
{
    const double gap = O->gap, epsilon = O->epsilon;
    if (O->law == RC_RIGID)  /* RigidObstacle.solve */
        return s <= gap ? 0.0 : (s - gap) / w;
    if (O->law == RC_LINEAR && !O->gradient)  /* LinearLaw.solve */
        return s <= gap ? 0.0 : (s - gap) / (epsilon + w);
    if (O->law == RC_LINEAR) {  /* LinearLaw.solve_gradient */
        double sigma = s - gap, e = c - gap, two_eps = 2.0 * epsilon;
        if (e <= 0.0) {
            if (sigma <= 0.0)
                return 0.0;
            double d = rc_positive_root(two_eps + w, -two_eps * (e + sigma), two_eps * sigma * e);
            return d * d / (2.0 * epsilon * (d - e));
        }
        if (sigma > w * e / two_eps)
            return (sigma + e) / (two_eps + w);
        double q = rc_positive_root(two_eps, two_eps * (e + sigma),
                                    e * (two_eps * sigma - w * e));
        return e * e / (2.0 * epsilon * (e + q));
    }
    /* ContactLaw.solve and solve_gradient */
    if (!O->gradient) {
        if (s <= gap)
            return 0.0;
        return rc_force(O, rc_monotone_root(O, s, w, c, gap, s));
    }
    if (s <= gap && c <= gap)
        return 0.0;
    const double lo = s - w * rc_gradient(O, s, c);
    return rc_gradient(O, rc_monotone_root(O, s, w, c, lo, s), c);
}

/* How far y moves for the increments (dTheta, dU) of nodes n-2 (ta, ua) and n-1 (tb, ub):
 * MasslessEnd.moved_by, its two blocks summed apart. */
static inline double rc_end_moved(const rc_end *E, double ta, double tb, double ua, double ub)
{
    return (E->theta[0] * ta + E->theta[1] * tb) + (E->u[0] * ua + E->u[1] * ub);
}

/* y of the state (Theta, U) of nodes n-2 (ta, ua) and n-1 (tb, ub): MasslessEnd.position. */
static inline double rc_end_position(const rc_end *E, double ta, double tb, double ua, double ub)
{
    return rc_end_moved(E, ta, tb, ua, ub) + E->constant;
}

/* MasslessEnd.settle for the linear law and the rigid obstacle (the laws whose series with the
 * last cell is the linear law O, in closed form; the others stay on the PETSc loop): the end's
 * U(1) where its equation holds at the free position y, g + epsilon p where the force
 * p = psi'(y) > 0 (exactly g for the rigid obstacle), else y. Returns p. */
static inline double rc_end_settle(const rc_end *E, const rc_obstacle *O, double y, double *u_1)
{
    const double force = rc_force(O, y);
    *u_1 = force > 0.0 ? O->gap + E->epsilon * force : y;
    return force;
}

#endif
