/*
 * band.h -- the banded substitutions of direct.c's step, z = C^-1 (R s + b) with C = P L U
 * (LAPACK's dgbtrf, partial pivoting), the rows of R s + b made and the state updated within
 * them. A part of direct.c, included by it after what it reads there (rk_problem, shape, the
 * rows, the node updates, the contact) and end.h: not a header of its own.
 *
 * The solve is dgbtrs's algorithm: the forward pass applies the interchange ipiv[j] and the column
 * j of L to the rows below j (an axpy); the backward pass is dtbsv's column-oriented
 * upper-triangular solve, which finishes z[j] at column j, highest first. The superdiagonals of U
 * beyond the last one with a non-zero entry, and the multipliers of L likewise, are dropped by the
 * caller (without pivoting U has only C's ku superdiagonals), and U's diagonal is stored as its
 * reciprocals (one multiplication in place of a division on the backward pass's chain of
 * dependences: the only rounding that differs from dgbtrs'). Without interchanges (ipiv[j] = j for
 * every j) the forward pass skips them, and the caller gives the same factors as node-blocked
 * recurrences too (rk_problem's fwd and bwd): forward_blocked and backward_blocked, two unknowns
 * at once.
 */
#ifndef RODFEM_BAND_H
#define RODFEM_BAND_H

#define KMAX 8 /* the widest band of the blocked substitutions (direct.py's KMAX) */

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

/* The energy rows of nodes e_ghost - 1 .. 0, which no node's update reached (accept_node's
 * lag). */
RK_INLINE void energy_tail(const rk_problem *P, const double *sp, double *energy, const shape S)
{
    for (int m = (P->e_ghost < P->n ? P->e_ghost : P->n) - 1; m >= 0; m--)
        *energy += energy_rows(P, sp, m, S);
}

/* dtbsv's backward pass, then the state update: returns the step's recorded p, and the new
 * state's energy. An eliminated end's p needs the nodes n-1 and n-2 solved, and their update
 * waits for it. *failed: the step's p could not be found (nothing is updated). */
RK_INLINE double backward(const rk_problem *P, double *sp, double *z, double *u_prev,
                          double *energy, int *failed, const shape S)
{
    const int ku = S.ku;
    const int N = 2 * P->n, eliminated = P->end.kind == RC_END_ELIMINATED;
    double p = 0.0, phi = 0.0, recorded = 0.0;
    *energy = 0.0;
    for (int j = N - 1; j >= 0; j--) {
        const double t = z[j] * P->rdiag[j];
        z[j] = t;
        const int top = j < ku ? j : ku;
        const double *col = P->upper + (size_t)j * ku;
        for (int i = 0; i < top; i++)
            z[j - 1 - i] -= t * col[i];
        if (eliminated && j >= N - 4) {
            if (j == N - 4) {
                const node_pair zb = {z[N - 2], z[N - 1]}, za = {z[N - 4], z[N - 3]};
                p = end_contact(P, sp, zb, za);
                recorded = eliminated_end(P, sp, u_prev, zb, za, p, &phi, energy, S);
            }
            continue;
        }
        if (j == N - 2) {  /* the last node's two columns are done */
            recorded = p = contact(P, sp, z[N - 1], t, &phi, failed);
            if (*failed)
                return 0.0;
        }
        if (!(j & 1))
            accept_node(P, sp, u_prev, j >> 1, z[j], z[j + 1], p, phi, j == N - 2, energy, S);
    }
    energy_tail(P, sp, energy, S);
    return recorded;
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

/* Node i of U x = y by nodes: x_i = D_i y_i - H_i x_(2i+2 .. 2i+1+ku), D_i the inverse of U's
 * diagonal block [[d00, -d01], [0, d11]], H_i = D_i U_(i, 2i+2 .. 2i+1+ku); win holds the last
 * ku values of x, and receives x_i. */
RK_INLINE node_pair solve_node(const rk_problem *P, const double *z, int i, double *win,
                               const shape S)
{
    const int ku = S.ku;
    const double *h = P->bwd + (size_t)i * (2 * ku + 3);
    const double y0 = z[2 * i], y1 = z[2 * i + 1];
    double x0 = h[0] * y0 - h[1] * y1, x1 = h[2] * y1;
#pragma GCC unroll 8
    for (int t = ku - 1; t >= 0; t--) {
        x0 -= h[3 + t] * win[2 + t];
        x1 -= h[3 + ku + t] * win[2 + t];
    }
    win[0] = x0;
    win[1] = x1;
#pragma GCC unroll 8
    for (int t = ku - 1; t >= 0; t--)
        win[2 + t] = win[t];
    const node_pair x = {x0, x1};
    return x;
}

/* U x = y by nodes, from the last (solve_node). The contact force is known after the first node
 * (an eliminated end's after the first two), each node's state updated as soon as it is solved
 * and p known. Returns the step's recorded p. */
RK_INLINE double backward_blocked(const rk_problem *P, double *sp, const double *z,
                                  double *u_prev, double *energy, int *failed, const shape S)
{
    const int n = P->n;
    double win[KMAX + 2], p, phi = 0.0, recorded;
    *energy = 0.0;
    for (int t = 0; t < S.ku; t++)
        win[2 + t] = 0.0;
    int i = n - 1;
    if (P->end.kind == RC_END_ELIMINATED) {
        const node_pair zb = solve_node(P, z, i--, win, S), za = solve_node(P, z, i--, win, S);
        p = end_contact(P, sp, zb, za);
        recorded = eliminated_end(P, sp, u_prev, zb, za, p, &phi, energy, S);
    } else {
        const node_pair x = solve_node(P, z, i, win, S);
        recorded = p = contact(P, sp, x.u, x.theta, &phi, failed);
        if (*failed)
            return 0.0;
        accept_node(P, sp, u_prev, i--, x.theta, x.u, p, phi, 1, energy, S);
    }
    for (; i >= 0; i--) {
        const node_pair x = solve_node(P, z, i, win, S);
        accept_node(P, sp, u_prev, i, x.theta, x.u, p, phi, 0, energy, S);
    }
    energy_tail(P, sp, energy, S);
    return recorded;
}

#endif
