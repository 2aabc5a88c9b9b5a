/*
 * record.h -- the raw row a compiled loop stores per step: rodfem/solver/record.py's RAW, slot
 * for slot (rodfem/solver/compiled/build.py checks the numbers when the loops are built), then
 * the scene's readings (rodfem/output/history.py's Readings: a field's value at a point).
 */
#ifndef RODFEM_RECORD_H
#define RODFEM_RECORD_H

#include <stddef.h>

/* cdef begin: the declarations cffi reads */
enum {
    RAW_N,            /* the step n */
    RAW_ITERATIONS,   /* the method's iterations of the step */
    RAW_U_1,          /* U^n(1) */
    RAW_D_1,          /* D^n(1) */
    RAW_U_HALF,       /* U^n(0.5) */
    RAW_BULK_ENERGY,  /* the energy but its contact term */
    RAW_PRESSURE,     /* the contact force p */
    RAW_SLOTS
};

/* The readings after the RAW_SLOTS slots of a row: reading r is
 *     constant[r] + sum over t = 0 .. terms - 1 of weight[r terms + t] s[index[r terms + t]]
 * in that order, for the state s = [Theta; D; U] in block order (index = part n + node). */
typedef struct {
    int count, terms;
    const int *index;       /* count x terms */
    const double *weight;   /* count x terms, zero-padded */
    const double *constant; /* count */
} rr_readings;
/* cdef end */

/* The readings of the state whose part k (0: Theta, 1: D, 2: U) at node i is
 * part[k][stride i], into out[0 .. count - 1]. */
static inline void rr_read(const rr_readings *R, int n, const double *const part[3], int stride,
                           double *out)
{
    for (int r = 0; r < R->count; r++) {
        double value = R->constant[r];
        for (int t = 0; t < R->terms; t++) {
            const int k = r * R->terms + t, i = R->index[k];
            value += R->weight[k] * part[i / n][(ptrdiff_t)stride * (i % n)];
        }
        out[r] = value;
    }
}

#endif
