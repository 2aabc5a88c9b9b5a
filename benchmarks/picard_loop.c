/*
 * picard_loop.c -- compiled C99 baseline of the Picard time loop (3.3)-(3.4) of
 * Copetti's thermoviscoelastic rod / elastic obstacle scheme (see
 * /work/shared/paper/README.md).  Used as a speed yardstick for the Python/PETSc
 * implementation.
 *
 * Build:  cc -O2 -std=c99 -Wall -o /tmp/picard_loop benchmarks/picard_loop.c -lm
 * Usage:  picard_loop cells dt end epsilon k zeta mass tol max_it [history_file]
 *         mass = "lumped" | "consistent"
 * Fixed data: a = 0.017, b = 1, theta_A = 10, g = 0.1.
 * The time loop is run REPEATS = 5 times and the fastest is reported; the environment
 * variable PICARD_LOOP_REPEATS (an integer >= 1) changes that count.
 *
 * Unknowns: P1 nodal values at x_i = i h, i = 1..s (h = 1/s); x_0 = 0 is excluded.
 * All vectors below are stored 1-based in arrays of length s + 2, with entry 0
 * a ghost that is always 0 (the clamped node), so that x_{i-1} needs no branch.
 *
 * Per Picard iteration (step n >= 2, iterate l):
 *   (M + dt K + dt k B) c^{n,l} = M c^{n-1} + a C (d^{n-1} - d^{n,l-1})
 *   (b M + (dt^2 + dt zeta) K) d^{n,l} = (2bM + dt zeta K) d^{n-1} - b M d^{n-2}
 *        - dt^2 a theta_A z + dt^2 a C^T c^{n,l} - (dt^2/eps) [d^{n,l-1}_s - g]_+ e
 * with, for row i < s and row s:
 *   (C x)_i   = (x_{i+1} - x_{i-1})/2,    (C x)_s   = (x_s - x_{s-1})/2
 *   (C^T x)_i = (x_{i-1} - x_{i+1})/2,    (C^T x)_s = (x_{s-1} + x_s)/2.
 *
 * Both matrices are factored once.  The heat matrix is factored "LU" (forward
 * elimination i = 1..s, back substitution i = s..1); the momentum matrix "UL"
 * (backward elimination i = s..1, forward substitution i = 1..s).  With these
 * directions each Picard iteration is two fused sweeps:
 *   sweep B (descending): heat back substitution -> c^{n,l}, and, one node
 *            behind, the momentum right-hand side and backward elimination;
 *   sweep A (ascending):  momentum forward substitution -> d^{n,l}, and, one node
 *            behind, the heat right-hand side and forward elimination for the
 *            iteration l+1 (discarded if iteration l has converged).
 * The two recurrences in each sweep are independent chains that the CPU overlaps.
 * The step-invariant parts of both right-hand sides are computed once per step.
 * Mathematically this is exactly the iteration above; only the rounding order
 * differs from a textbook implementation.
 */
#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define A_COUP 0.017
#define B_MASS 1.0
#define THETA_A 10.0
#define GAP 0.1
#define REPEATS 5

typedef struct {
    int s;            /* cells = unknowns */
    long N;           /* time steps */
    double dt, eps, k, zeta, tol;
    int max_it;
    /* mass matrix M: off-diagonal, interior diagonal, last diagonal */
    double Mo, Md, Mds;
    /* P = 2bM + dt zeta K, Q = bM (step-invariant momentum RHS) */
    double Po, Pd, Pds, Qo, Qd, Qds;
    /* heat factor (LU, normalised): g_i = f_i*hp_i - hq_i*g_{i-1}; c_i = g_i - hcp_i*c_{i+1} */
    double *hp, *hq, *hcp;
    /* momentum factor (UL, normalised): g_i = f_i*mp_i - mq_i*g_{i+1}; d_i = g_i - mcq_i*d_{i-1} */
    double *mp, *mq, *mcq;
    double *zt;       /* dt^2 a theta_A z_i */
    double *c0, *d0, *d1; /* initial data Theta^0, U^0, U^1 */
} Problem;

typedef struct {
    double *c, *d, *dp;       /* current c, current d, previous d */
    double *hc, *mc, *gH, *gM; /* step constants and elimination workspaces */
    double *u1;               /* U^n(1), n = 0..N */
    int *its;                 /* Picard iterations of step n, n = 0..N */
} Work;

static double *vec(int s)
{
    double *v = calloc((size_t)s + 2, sizeof(double));
    if (!v) {
        fprintf(stderr, "picard_loop: out of memory\n");
        exit(1);
    }
    return v;
}

static double r_fun(double x, double cc) { return cc * x - 1.0; }

static void setup(Problem *P, int lumped)
{
    const int s = P->s;
    const double h = 1.0 / s, dt = P->dt, b = B_MASS;
    const double cc = P->k / (P->k + 1.0);
    const double pi = acos(-1.0);
    int i;

    if (lumped) {
        P->Mo = 0.0; P->Md = h; P->Mds = 0.5 * h;
    } else {
        P->Mo = h / 6.0; P->Md = 2.0 * h / 3.0; P->Mds = h / 3.0;
    }
    const double Ko = -1.0 / h, Kd = 2.0 / h, Kds = 1.0 / h;
    P->Po = 2.0 * b * P->Mo + dt * P->zeta * Ko;
    P->Pd = 2.0 * b * P->Md + dt * P->zeta * Kd;
    P->Pds = 2.0 * b * P->Mds + dt * P->zeta * Kds;
    P->Qo = b * P->Mo; P->Qd = b * P->Md; P->Qds = b * P->Mds;

    /* heat matrix A1 = M + dt K + dt k B, LU (forward elimination) */
    {
        const double off = P->Mo + dt * Ko;
        double cprev = 0.0;
        P->hp = vec(s); P->hq = vec(s); P->hcp = vec(s);
        for (i = 1; i <= s; i++) {
            double diag = (i < s) ? P->Md + dt * Kd : P->Mds + dt * Kds + dt * P->k;
            double lo = (i > 1) ? off : 0.0, up = (i < s) ? off : 0.0;
            double m = diag - lo * cprev;
            P->hp[i] = 1.0 / m;
            P->hq[i] = lo / m;
            P->hcp[i] = up / m;
            cprev = P->hcp[i];
        }
    }
    /* momentum matrix A2 = bM + (dt^2 + dt zeta) K, UL (backward elimination) */
    {
        const double kk = dt * dt + dt * P->zeta;
        const double off = b * P->Mo + kk * Ko;
        double cnext = 0.0;
        P->mp = vec(s); P->mq = vec(s); P->mcq = vec(s);
        for (i = s; i >= 1; i--) {
            double diag = (i < s) ? b * P->Md + kk * Kd : b * P->Mds + kk * Kds;
            double lo = (i > 1) ? off : 0.0, up = (i < s) ? off : 0.0;
            double m = diag - up * cnext;
            P->mp[i] = 1.0 / m;
            P->mq[i] = up / m;
            P->mcq[i] = lo / m;
            cnext = P->mcq[i];
        }
    }
    /* z_i = (r, eta_i') = r(mid of left cell) - r(mid of right cell); last: r(mid of last cell) */
    P->zt = vec(s);
    for (i = 1; i <= s; i++) {
        double xi = i * h;
        double z = r_fun(xi - 0.5 * h, cc) - ((i < s) ? r_fun(xi + 0.5 * h, cc) : 0.0);
        P->zt[i] = dt * dt * A_COUP * THETA_A * z;
    }
    /* initial data */
    P->c0 = vec(s); P->d0 = vec(s); P->d1 = vec(s);
    for (i = 1; i <= s; i++) {
        double x = i * h;
        double th0 = THETA_A * (cos(2.0 * pi * x) - sin(0.5 * pi * x));
        P->c0[i] = th0 + THETA_A * r_fun(x, cc);
        P->d0[i] = 0.0;                                         /* u0 = 0 */
        P->d1[i] = P->d0[i] + dt * (20.0 * x * (x - 1.0) * (x - 1.0)); /* + dt u1 */
    }
}

/* One full run of the time loop n = 1..N from the initial state.  Returns 0, or 3
 * if the Picard iteration did not converge within max_it. */
static int run(const Problem *P, Work *W)
{
    const int s = P->s, max_it = P->max_it;
    const long N = P->N;
    const double dt = P->dt, tol = P->tol;
    const double w = 0.5 * A_COUP;                 /* a/2: a C x */
    const double wd2 = 0.5 * dt * dt * A_COUP;     /* dt^2 a/2: dt^2 a C^T x */
    const double dte = dt * dt / P->eps;
    const double Mo = P->Mo, Md = P->Md, Mds = P->Mds;
    const double Po = P->Po, Pd = P->Pd, Pds = P->Pds;
    const double Qo = P->Qo, Qd = P->Qd, Qds = P->Qds;
    const double *restrict hp = P->hp, *restrict hq = P->hq, *restrict hcp = P->hcp;
    const double *restrict mp = P->mp, *restrict mq = P->mq, *restrict mcq = P->mcq;
    const double *restrict zt = P->zt;
    double *restrict c = W->c, *restrict d = W->d, *restrict dp = W->dp;
    double *restrict hc = W->hc, *restrict mc = W->mc;
    double *restrict gH = W->gH, *restrict gM = W->gM;
    double *restrict u1 = W->u1;
    int *restrict its = W->its;
    long n;
    int i;

    /* state at n = 1: c = Theta^0, dp = U^0, d = U^1 (ghost entries stay 0) */
    memcpy(c, P->c0, (size_t)(s + 2) * sizeof(double));
    memcpy(dp, P->d0, (size_t)(s + 2) * sizeof(double));
    memcpy(d, P->d1, (size_t)(s + 2) * sizeof(double));
    u1[0] = dp[s]; its[0] = 0;
    u1[1] = d[s];  its[1] = 0;

    /* n = 1: heat equation only, (M + dt K + dt k B) Theta^1 = M Theta^0 + a C (U^0 - U^1) */
    {
        double g = 0.0, x;
        for (i = 1; i < s; i++) {
            double f = Mo * (c[i - 1] + c[i + 1]) + Md * c[i]
                     + w * ((dp[i + 1] - d[i + 1]) - (dp[i - 1] - d[i - 1]));
            g = f * hp[i] - hq[i] * g;
            gH[i] = g;
        }
        {
            double f = Mo * c[s - 1] + Mds * c[s]
                     + w * ((dp[s] - d[s]) - (dp[s - 1] - d[s - 1]));
            g = f * hp[s] - hq[s] * g;
        }
        x = g;
        c[s] = x;
        for (i = s - 1; i >= 1; i--) {
            x = gH[i] - hcp[i] * x;
            c[i] = x;
        }
    }

    for (n = 2; n <= N; n++) {
        /* Step constants from c = Theta^{n-1}, d = U^{n-1}, dp = U^{n-2}:
         *   hc = M c^{n-1} + a C d^{n-1}
         *   mc = (2bM + dt zeta K) d^{n-1} - bM d^{n-2} - dt^2 a theta_A z
         * and the heat forward elimination for l = 1, whose RHS is M c^{n-1}
         * (the coupling term vanishes since d^{n,0} = d^{n-1}). */
        {
            double g = 0.0;
            for (i = 1; i < s; i++) {
                double Mc = Mo * (c[i - 1] + c[i + 1]) + Md * c[i];
                hc[i] = Mc + w * (d[i + 1] - d[i - 1]);
                mc[i] = Po * (d[i - 1] + d[i + 1]) + Pd * d[i]
                      - (Qo * (dp[i - 1] + dp[i + 1]) + Qd * dp[i]) - zt[i];
                g = Mc * hp[i] - hq[i] * g;
                gH[i] = g;
            }
            {
                double Mc = Mo * c[s - 1] + Mds * c[s];
                hc[s] = Mc + w * (d[s] - d[s - 1]);
                mc[s] = Po * d[s - 1] + Pds * d[s] - (Qo * dp[s - 1] + Qds * dp[s]) - zt[s];
                g = Mc * hp[s] - hq[s] * g;
                gH[s] = g;
            }
            memcpy(dp + 1, d + 1, (size_t)s * sizeof(double)); /* dp = U^{n-1} */
        }

        int l;
        for (l = 1; l <= max_it; l++) {
            double incc, incd, e;

            /* Sweep B (i = s..1): c^{n,l} in place (heat back substitution);
             * one node behind, momentum RHS and backward elimination. */
            {
                double pen = d[s] - GAP;          /* d[s] = d^{n,l-1}_s */
                pen = (pen > 0.0) ? dte * pen : 0.0;
                double x2 = gH[s];                /* c_s */
                incc = fabs(x2 - c[s]);
                c[s] = x2;
                double x1 = gH[s - 1] - hcp[s - 1] * x2; /* c_{s-1} */
                e = fabs(x1 - c[s - 1]);
                incc = (e > incc) ? e : incc;
                c[s - 1] = x1;
                double gm = (mc[s] + wd2 * (x1 + x2) - pen) * mp[s];
                gM[s] = gm;
                /* x1 = c_{i+1}, x2 = c_{i+2} */
                for (i = s - 2; i >= 1; i--) {
                    double ci = gH[i] - hcp[i] * x1;
                    e = fabs(ci - c[i]);
                    incc = (e > incc) ? e : incc;
                    c[i] = ci;
                    gm = (mc[i + 1] + wd2 * (ci - x2)) * mp[i + 1] - mq[i + 1] * gm;
                    gM[i + 1] = gm;
                    x2 = x1;
                    x1 = ci;
                }
                /* now x1 = c_1, x2 = c_2; row 1 of C^T c is (0 - c_2)/2 */
                gm = (mc[1] - wd2 * x2) * mp[1] - mq[1] * gm;
                gM[1] = gm;
            }

            /* Sweep A (i = 1..s): d^{n,l} in place (momentum forward substitution);
             * one node behind, heat RHS and forward elimination for l + 1. */
            {
                double y1 = gM[1];                /* d_1 */
                double y2 = 0.0;                  /* d_0 */
                double g = 0.0;
                incd = fabs(y1 - d[1]);
                d[1] = y1;
                /* y1 = d_{i-1}, y2 = d_{i-2} */
                for (i = 2; i <= s; i++) {
                    double di = gM[i] - mcq[i] * y1;
                    e = fabs(di - d[i]);
                    incd = (e > incd) ? e : incd;
                    d[i] = di;
                    g = (hc[i - 1] - w * (di - y2)) * hp[i - 1] - hq[i - 1] * g;
                    gH[i - 1] = g;
                    y2 = y1;
                    y1 = di;
                }
                /* last row of C d: (d_s - d_{s-1})/2 */
                g = (hc[s] - w * (y1 - y2)) * hp[s] - hq[s] * g;
                gH[s] = g;
            }

            if (incc < tol && incd < tol)
                break;
        }
        if (l > max_it) {
            fprintf(stderr, "picard_loop: Picard iteration did not converge in %d "
                            "iterations at step n = %ld (t = %g)\n", max_it, n, n * dt);
            return 3;
        }
        its[n] = l;
        u1[n] = d[s];
    }
    return 0;
}

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void usage(void)
{
    fprintf(stderr, "usage: picard_loop cells dt end epsilon k zeta mass tol max_it "
                    "[history_file]\n       mass = lumped | consistent\n");
    exit(2);
}

int main(int argc, char **argv)
{
    Problem P;
    Work W;
    int lumped, rep, rc = 0, repeats = REPEATS;
    long n;
    double best = HUGE_VAL;
    const char *repeats_env = getenv("PICARD_LOOP_REPEATS");

    if (argc != 10 && argc != 11)
        usage();
    memset(&P, 0, sizeof P);
    P.s = atoi(argv[1]);
    P.dt = atof(argv[2]);
    double T = atof(argv[3]);
    P.eps = atof(argv[4]);
    P.k = atof(argv[5]);
    P.zeta = atof(argv[6]);
    if (strcmp(argv[7], "lumped") == 0)
        lumped = 1;
    else if (strcmp(argv[7], "consistent") == 0)
        lumped = 0;
    else
        usage();
    P.tol = atof(argv[8]);
    P.max_it = atoi(argv[9]);
    if (P.s < 2 || !(P.dt > 0.0) || !(T > 0.0) || !(P.eps > 0.0) || P.k < 0.0 ||
        P.zeta < 0.0 || P.max_it < 1) {
        fprintf(stderr, "picard_loop: need cells >= 2, dt > 0, end > 0, epsilon > 0, "
                        "k >= 0, zeta >= 0, max_it >= 1\n");
        return 2;
    }
    if (repeats_env != NULL) {
        repeats = atoi(repeats_env);
        if (repeats < 1) {
            fprintf(stderr, "picard_loop: PICARD_LOOP_REPEATS must be an integer >= 1\n");
            return 2;
        }
    }
    P.N = (long)floor(T / P.dt + 0.5);
    if (P.N < 2) {
        fprintf(stderr, "picard_loop: need at least 2 time steps\n");
        return 2;
    }

    setup(&P, lumped);
    W.c = vec(P.s); W.d = vec(P.s); W.dp = vec(P.s);
    W.hc = vec(P.s); W.mc = vec(P.s); W.gH = vec(P.s); W.gM = vec(P.s);
    W.u1 = malloc((size_t)(P.N + 1) * sizeof(double));
    W.its = malloc((size_t)(P.N + 1) * sizeof(int));
    if (!W.u1 || !W.its) {
        fprintf(stderr, "picard_loop: out of memory\n");
        return 1;
    }

    for (rep = 0; rep < repeats; rep++) {
        double t0 = now_s();
        rc = run(&P, &W);
        double t1 = now_s();
        if (rc != 0)
            return rc;
        if (t1 - t0 < best)
            best = t1 - t0;
    }

    long itsum = 0;
    int itmax = 0;
    for (n = 2; n <= P.N; n++) {
        itsum += W.its[n];
        if (W.its[n] > itmax)
            itmax = W.its[n];
    }
    printf("{\"cells\": %d, \"steps\": %ld, \"us_per_step\": %.6g, "
           "\"iterations_mean\": %.17g, \"iterations_max\": %d, \"u_1_final\": %.17g}\n",
           P.s, P.N, 1e6 * best / (double)P.N, (double)itsum / (double)(P.N - 1), itmax,
           W.u1[P.N]);

    if (argc == 11) {
        FILE *f = fopen(argv[10], "w");
        if (!f) {
            fprintf(stderr, "picard_loop: cannot open %s\n", argv[10]);
            return 1;
        }
        for (n = 0; n <= P.N; n++)
            fprintf(f, "%.17g,%.17g,%d\n", (double)n * P.dt, W.u1[n], W.its[n]);
        fclose(f);
    }
    return 0;
}
