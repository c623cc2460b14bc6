/* The runtime of every generated model (hybridhyst.simulate.fast.codegen pastes it before the model's
   kernels): the non-smooth functions of physics/symbolic.py with the reference's derivative conventions,
   and the small MLP kernels of networks inside the equations. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define DIM(n) ((n) > 0 ? (n) : 1) /* a C array needs at least one element */

static inline double _sign(double x) { return x > 0 ? 1.0 : (x < 0 ? -1.0 : 0.0); }

static inline double _step(double x) { return x >= 0 ? 1.0 : 0.0; }

static inline double _abs_pow(double z, double n) {
    double a = fabs(z);
    return a > 0 ? pow(a, n) : 0.0;
}

static inline double _abs_pow_log(double z, double n) {
    double a = fabs(z);
    return a > 0 ? pow(a, n) * log(a) : 0.0;
}

/* Activation by code: 0 tanh, 1 relu, 2 gelu (erf), 3 silu, 4 elu (as torch.nn). */
static inline double _act(double z, int kind) {
    switch (kind) {
    case 0: return tanh(z);
    case 1: return z > 0.0 ? z : 0.0;
    case 2: return 0.5 * z * (1.0 + erf(z / sqrt(2.0)));
    case 3: return z / (1.0 + exp(-z));
    default: return z > 0.0 ? z : exp(z) - 1.0;
    }
}

/* Derivative of the activation at z (a = its value), with torch's conventions at the kinks. */
static inline double _dact(double z, double a, int kind) {
    switch (kind) {
    case 0: return 1.0 - a * a;
    case 1: return z > 0.0 ? 1.0 : 0.0;
    case 2: return 0.5 * (1.0 + erf(z / sqrt(2.0))) + z * exp(-0.5 * z * z) / sqrt(2.0 * M_PI);
    case 3: { double sg = 1.0 / (1.0 + exp(-z)); return sg * (1.0 + z * (1.0 - sg)); }
    default: return z > 0.0 ? 1.0 : exp(z);
    }
}

/* An MLP (torch layout: per layer its weight (out, in) row by row, then its bias, from th[off]) at x:
   Z[l] before and A[l + 1] after layer l's activation (none after the last); A[0] = x. Z is (L, width),
   A (L + 1, width), row-major. */
static inline void _mlp_forward(const double *x, const double *th, int off, const int *widths, int L, int act,
                                double *Z, double *A, int width) {
    for (int i = 0; i < widths[0]; i++) A[i] = x[i];
    int o = off;
    for (int l = 0; l < L; l++) {
        int a = widths[l], b = widths[l + 1];
        const double *prev = A + l * width;
        for (int j = 0; j < b; j++) {
            double acc = th[o + a * b + j];
            const double *row = th + o + j * a;
            for (int i = 0; i < a; i++) acc += row[i] * prev[i];
            Z[l * width + j] = acc;
            A[(l + 1) * width + j] = l == L - 1 ? acc : _act(acc, act);
        }
        o += (a + 1) * b;
    }
}

/* Back-propagate v = dfdn^T w through the MLP evaluated in Z, A: its weights' gradient into gth[off:], its
   inputs' gradient through their Jacobians into lam (state, ns), gth[:np] (parameters) and gin (inputs).
   dfdn (ne, n_out), dins (n_in, ns), dinth (n_in, np), dinin (n_in, ni) (ni inputs: u, du, ddu, controls). */
static inline void _network_vjp(const double *w, int ne, const double *dfdn, const double *dins, int ns,
                                const double *dinth, int np, const double *dinin, int ni, const double *th, int off,
                                const int *widths, int L, int act, const double *Z, const double *A, int width,
                                double *lam, double *gth, double *gin) {
    double g[width], gp[width];
    int offs[L];
    for (int j = 0; j < widths[L]; j++) {
        double acc = 0.0;
        for (int i = 0; i < ne; i++) acc += dfdn[i * widths[L] + j] * w[i];
        g[j] = acc;
    }
    int o = off;
    for (int l = 0; l < L; l++) {
        offs[l] = o;
        o += (widths[l] + 1) * widths[l + 1];
    }
    for (int l = L - 1; l >= 0; l--) {
        int a = widths[l], b = widths[l + 1];
        o = offs[l];
        const double *prev = A + l * width;
        for (int i = 0; i < a; i++) gp[i] = 0.0;
        for (int j = 0; j < b; j++) {
            double gj = g[j];
            if (gj != 0.0) {
                gth[o + a * b + j] += gj;
                double *grow = gth + o + j * a;
                const double *row = th + o + j * a;
                for (int i = 0; i < a; i++) {
                    grow[i] += gj * prev[i];
                    gp[i] += row[i] * gj;
                }
            }
        }
        if (l > 0)
            for (int i = 0; i < a; i++) g[i] = gp[i] * _dact(Z[(l - 1) * width + i], A[l * width + i], act);
    }
    for (int a = 0; a < widths[0]; a++) {
        double ga = gp[a];
        if (ga != 0.0) {
            for (int r = 0; r < ns; r++) lam[r] += ga * dins[a * ns + r];
            for (int p = 0; p < np; p++) gth[p] += ga * dinth[a * np + p];
            for (int q = 0; q < ni; q++) gin[q] += ga * dinin[a * ni + q];
        }
    }
}
