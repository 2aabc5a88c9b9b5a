/*
 * end.h -- the eliminated massless end in direct.c's step (contact.h's rc_end, RC_END_ELIMINATED;
 * rodfem/solver/methods/massless.py): the contact law in series with the last cell, taken at the
 * end's free position y, a row on Theta and U of nodes n-2 and n-1, and the end settled once both
 * are updated; band.h's backward passes call it. A part of direct.c, included by it after what it
 * reads there (rk_problem, shape, node_pair, update_node, energy_rows): not a header of its own.
 */
#ifndef RODFEM_END_H
#define RODFEM_END_H

/* The eliminated end (contact.h's rc_end; DirectMethod._step with a MasslessEnd), in two parts
 * around the update of nodes n-1 and n-2, which wait for each other. First the step's p: the
 * law in series at y, from c = y of the old state and the free increments zb of node n-1 and za
 * of node n-2. */
RK_INLINE double end_contact(const rk_problem *P, const double *sp, node_pair zb, node_pair za)
{
    const rc_end *E = &P->end;
    const double *sa = sp + 3 * (ptrdiff_t)(P->n - 2), *sb = sa + 3;
    const double c = rc_end_position(E, sa[0], sb[0], sa[2], sb[2]);
    const double s1 = c + rc_end_moved(E, za.theta, zb.theta, za.u, zb.u);
    return rc_contact_needed(&P->obstacle, s1, c) ? rc_solve(&P->obstacle, s1, P->w, c) : 0.0;
}

/* Then, once both are updated (U(1) was u_old), the end settled; a variable exchange's flux
 * *phi at the settled end (DirectMethod._exchange: q at U^n(1) and the step's force p, T0 from
 * Theta^(n-1)(1) = theta_old and the free increment z_theta; a = 0, so beta = 0) added to both
 * nodes' Theta; and the energy rows that the update of both would have summed, now that they
 * read the settled end. Returns the settled force, the step's recorded p. */
RK_INLINE double end_settle(const rk_problem *P, double *sp, double u_old, double theta_old,
                            double z_theta, double p, double *phi, double *energy,
                            const shape S)
{
    const rc_end *E = &P->end;
    const int n = P->n;
    double *sa = sp + 3 * (ptrdiff_t)(n - 2), *sb = sa + 3;
    double u_1;
    const double y = rc_end_position(E, sa[0], sb[0], sa[2], sb[2]);
    const double force = rc_end_settle(E, &P->obstacle, y, &u_1);
    sb[2] = u_1;
    sb[1] = u_1 - u_old;
    *phi = 0.0;
    if (P->exchange.law != RX_CONSTANT) {
        const rx_exchange *X = &P->exchange;
        const double T0 = (theta_old + X->offset) + X->weight * z_theta;
        const double q = rx_extra(X, rx_place(X, u_1, u_old), p);
        if (q != 0.0)
            *phi = q * ((T0 + X->weight * X->beta * p) / (1.0 - X->weight * X->gamma * q));
        if (*phi != 0.0) {
            sb[0] += *phi * P->qh[2 * (size_t)(n - 1)];
            sa[0] += *phi * P->qh[2 * (size_t)(n - 2)];
        }
    }
    for (int i = n - 1; i >= n - 2; i--)
        if (i + P->e_ghost < n)
            *energy += energy_rows(P, sp, i + P->e_ghost, S);
    return force;
}

/* The update of nodes n-1 (zb) and n-2 (za) by x = z + p q, p = end_contact's, and end_settle.
 * Returns the recorded p, and in *phi the exchange's flux, for the other nodes' update. */
RK_INLINE double eliminated_end(const rk_problem *P, double *sp, double *u_prev, node_pair zb,
                                node_pair za, double p, double *phi, double *energy,
                                const shape S)
{
    const int n = P->n;
    const double u_old = sp[3 * (ptrdiff_t)(n - 1) + 2], theta_old = sp[3 * (ptrdiff_t)(n - 1)];
    update_node(P, sp, u_prev, n - 1, zb.theta, zb.u, p, 0.0, 1);
    update_node(P, sp, u_prev, n - 2, za.theta, za.u, p, 0.0, 0);
    return end_settle(P, sp, u_old, theta_old, zb.theta, p, phi, energy, S);
}

#endif
