/*
 * picard_form.h -- the pk_problem of a step size formed from the operators' Laurent parts
 * (rodfem/solver/compiled/family_picard.py): an adaptive run's new step size in microseconds. A
 * part of picard.c, included by it after pk_problem, pk_family and pk_factor: not a header of its
 * own.
 *
 * At lam = dt0/h every coefficient is P0 + P1 lam + P2 lam^2 (laurent.py's combine, the same
 * operations in the same order); A_h and A_m are factored by pk_factor and their factors laid
 * out per node as the sweeps read them, as picard.py's PicardKernel does.
 */
#ifndef RODFEM_PICARD_FORM_H
#define RODFEM_PICARD_FORM_H

static size_t pk_layout(const pk_family *F, size_t *at)
{
    const size_t n = F->n;
    const size_t sizes[6] = {(size_t)F->fixed_classes * 20, (size_t)F->coupling_classes * 8,
                             6 * n, 6 * n, 6 * n, 10 * (n + 2)};
    size_t total = 0;
    for (int k = 0; k < 6; k++) {
        at[k] = total;
        total += sizes[k];
    }
    return total;
}

long pk_form_size(const pk_family *F)
{
    size_t at[6];
    return (long)pk_layout(F, at);
}

static void pk_combine(const double *parts, size_t count, double lam, double *out)
{
    for (size_t k = 0; k < count; k++)
        out[k] = parts[k] + parts[count + k] * lam + parts[2 * count + k] * (lam * lam);
}

int pk_form(const pk_family *F, double lam, pk_problem *P, double *memory)
{
    const int n = F->n;
    size_t at[6];
    pk_layout(F, at);
    double *fixed = memory + at[0], *coupling = memory + at[1], *tri = memory + at[2];
    double *factors = memory + at[3], *sweeps = memory + at[4], *work = memory + at[5];
    pk_combine(F->fixed_parts, (size_t)F->fixed_classes * 20, lam, fixed);
    pk_combine(F->coupling_parts, (size_t)F->coupling_classes * 8, lam, coupling);
    pk_combine(F->operator_parts, 6 * (size_t)n, lam, tri);
    for (int ul = 0; ul < 2; ul++) {  /* A_h's L U, A_m's U L */
        const double *t = tri + 3 * (size_t)n * ul;
        const int info = pk_factor(n, t, t + n, t + 2 * (size_t)n, ul,
                                   factors + 3 * (size_t)n * ul, 3);
        if (info)
            return info;
    }
    const double *heat = factors, *momentum = factors + 3 * (size_t)n;
    double *descending = sweeps, *ascending = sweeps + 3 * (size_t)n;
    for (int i = 0; i < n; i++) {
        descending[3 * i] = heat[3 * i + 2];
        descending[3 * i + 1] = momentum[3 * i];
        descending[3 * i + 2] = momentum[3 * i + 1];
        ascending[3 * i] = momentum[3 * i + 2];
        ascending[3 * i + 1] = heat[3 * i];
        ascending[3 * i + 2] = heat[3 * i + 1];
    }
    P->fixed = fixed;
    P->coupling = coupling;
    P->descending = descending;
    P->ascending = ascending;
    P->work = work;
    return 0;
}

#endif
