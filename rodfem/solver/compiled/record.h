/*
 * record.h -- the raw row a compiled loop stores per step: rodfem/solver/record.py's RAW, slot
 * for slot (rodfem/solver/compiled/build.py checks the numbers when the loops are built).
 */
#ifndef RODFEM_RECORD_H
#define RODFEM_RECORD_H

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
/* cdef end */

#endif
