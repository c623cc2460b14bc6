/* The integration loops of every generated model (hybridhyst.simulate.fast.codegen pastes them after the
   model's kernels ``bounds``, ``rhs``, ``rhs_jac``, ``out``, ``out_jac``, ``rhs_net_vjp``, ``out_net_vjp`` and its
   sizes S, P, O, NI, NB, HAS_BOUNDS, NETS). Arrays are row-major float64: U (B, T, NI) the input, its two rates and
   the control channels,
   h (B, T - 1) each row's sample intervals, th (B, NT) each row's P parameter values then the networks'
   weights, s0 (B, S), states (B, T, S), y (B, T, O). The explicit Runge-Kutta tableau is c (nst), A (nst, nst),
   bw (nst); ``sub`` sub-steps per sample interval, the input linearly interpolated inside it. The exported
   functions run rows [b0, b1): the caller spreads rows over threads. A library holds one of them: hh_forward
   (HH_FORWARD, the values source), hh_tangent (HH_TANGENT) or hh_backward (HH_BACKWARD, the derivatives source). */

/* Y = st + hk * sum_l A[j, l] K[l] (the state at stage j). */
static inline void stage_state(const double *st, const double *K, int j, double hk, const double *A, int nst,
                               double *Y) {
    for (int i = 0; i < S; i++) {
        double acc = st[i];
        for (int l = 0; l < j; l++) acc += hk * A[j * nst + l] * K[l * DIM(S) + i];
        Y[i] = acc;
    }
}

/* The inputs (u, du, ddu, controls) a fraction fr into sample interval k (linear interpolation). */
static inline void stage_input(const double *U, int k, double fr, double *in) {
    for (int q = 0; q < NI; q++) in[q] = U[k * NI + q] + (U[(k + 1) * NI + q] - U[k * NI + q]) * fr;
}

static const double ZERO_IN[NI] = {0}; /* the inputs where the state bounds are evaluated (they read none) */

/* Row b's th (nt columns) followed by the values the kernels read instead of evaluating them at every stage (powers
   and functions of the parameters alone: ``hoisted``), in a copy the caller frees. */
static double *with_hoisted(const double *th, long nt) {
    double *thx = malloc(sizeof(double) * DIM((nt > NTH ? nt : NTH) + NH));
    memcpy(thx, th, sizeof(double) * nt);
    hoisted(thx);
    return thx;
}

/* Advance st in place by sub-step m of interval k. */
static inline void substep(int k, int m, double *st, double *K, double *Y, double hk, const double *U,
                           const double *th, int nst, const double *c, const double *A, const double *bw, int sub,
                           double *buf) {
    double in[NI];
    for (int j = 0; j < nst; j++) {
        stage_state(st, K, j, hk, A, nst, Y);
        stage_input(U, k, (m + c[j]) / sub, in);
        rhs(Y, in, th, K + j * DIM(S), buf);
    }
    for (int i = 0; i < S; i++) {
        double acc = 0.0;
        for (int j = 0; j < nst; j++) acc += bw[j] * K[j * DIM(S) + i];
        st[i] += hk * acc;
    }
}

/* Project the state onto its bounds; fl[i] = 1 / -1 where the upper / lower bound was taken, else 0. */
static inline void project(double *st, const double *lo, const double *hi, double *fl) {
    for (int i = 0; i < S; i++) {
        if (st[i] > hi[i]) {
            st[i] = hi[i];
            fl[i] = 1.0;
        } else if (st[i] < lo[i]) {
            st[i] = lo[i];
            fl[i] = -1.0;
        } else {
            fl[i] = 0.0;
        }
    }
}

#ifdef HH_FORWARD
static void forward_row(int T, const double *U, const double *h, const double *th, const double *s0, int nst,
                        const double *c, const double *A, const double *bw, int sub, double *states, double *y) {
    double K[nst * DIM(S)], Y[DIM(S)], st[DIM(S)], g[DIM(O)], buf[NB];
    double lo[DIM(S)], hi[DIM(S)], fl[DIM(S)], dlo[DIM(S * P)], dhi[DIM(S * P)];
    memset(K, 0, sizeof K);
    for (int i = 0; i < S; i++) st[i] = s0[i];
    if (HAS_BOUNDS) bounds(st, ZERO_IN, th, lo, hi, dlo, dhi);
    for (int i = 0; i < S; i++) states[i] = st[i];
    for (int k = 0; k < T - 1; k++) {
        double hk = h[k] / sub;
        for (int m = 0; m < sub; m++) {
            substep(k, m, st, K, Y, hk, U, th, nst, c, A, bw, sub, buf);
            if (HAS_BOUNDS) project(st, lo, hi, fl);
        }
        for (int i = 0; i < S; i++) states[(k + 1) * S + i] = st[i];
    }
    for (int k = 0; k < T; k++) {
        out(states + k * S, U + k * NI, th, g, buf);
        for (int o = 0; o < O; o++) y[k * O + o] = g[o];
    }
}
#endif /* HH_FORWARD */

#ifdef HH_TANGENT
typedef void (*jac_kernel)(const double *, const double *, const double *, double *, double *, double *, double *,
                           double *);
typedef void (*vjp_kernel)(const double *, const double *, const double *, const double *, double *, double *,
                           double *, double *);

/* n values v of a kernel (the right-hand side, n = S; the outputs, n = O) and their whole Jacobians w.r.t. the
   state, vs (n, S), w.r.t. all nt columns of th, vt (n, nt), and w.r.t. the inputs, vi (n, NI): jac's (every
   network's output held) plus, with networks, their share row by row (one back-propagation through the layers per
   value, vjp with a unit weight). */
static inline void jac_full(jac_kernel jac, vjp_kernel vjp, int n, const double *Y, const double *in,
                            const double *th, int nt, double *v, double *vs, double *vt, double *vi, double *buf) {
    double VT[DIM(n * P)], w[DIM(n)], gin[DIM(NI)];
    jac(Y, in, th, v, vs, VT, vi, buf);
    for (int i = 0; i < n; i++)
        for (int p = 0; p < nt; p++) vt[i * nt + p] = p < P ? VT[i * P + p] : 0.0;
    if (NETS)
        for (int i = 0; i < n; i++) {
            for (int r = 0; r < n; r++) w[r] = r == i ? 1.0 : 0.0;
            for (int q = 0; q < NI; q++) gin[q] = 0.0;
            vjp(Y, in, th, w, vs + i * S, vt + i * nt, gin, buf);
            for (int q = 0; q < NI; q++) vi[i * NI + q] += gin[q];
        }
}

/* Where the input itself moves with some columns of th (a delay: the structure reads u(t - tau)): add to each of
   the n values' column derivatives vt (n, nt) its inputs' share, vi (n, NI) times the input's derivative din (NI)
   times each column's factor dth (nt; 0: the input does not move with that column). */
static inline void input_share(int n, int nt, const double *vi, const double *din, const double *dth, double *vt) {
    for (int i = 0; i < n; i++) {
        double a = 0.0;
        for (int q = 0; q < NI; q++) a += vi[i * NI + q] * din[q];
        if (a != 0.0)
            for (int p = 0; p < nt; p++)
                if (dth[p] != 0.0) vt[i * nt + p] += a * dth[p];
    }
}

/* The columns of th (of nt) a row's state tangent carries, into cols; their number. Of the columns asked for
   (want[p] != 0): a parameter that reaches the state (LIVE), every weight where the right-hand side reads a
   network, a column the input moves with (dth[p] != 0, dth NULL: none) and any column the start state's
   derivatives ds0 (S, nt) hold. Any other column's state tangent is zero (its derivative reaches the outputs
   directly) or not asked for, and the loop leaves it out. */
static int state_columns(int nt, const double *ds0, const double *want, const double *dth, int *cols) {
    int n = 0;
    for (int p = 0; p < nt; p++) {
        if (want[p] == 0.0) continue;
        int live = (p < P ? LIVE[p] : RHS_NETS) || (dth && dth[p] != 0.0);
        for (int i = 0; i < S && !live; i++) live = ds0[i * nt + p] != 0.0;
        if (live) cols[n++] = p;
    }
    return n;
}

/* One row of a chain rule over the state's columns: row[c] = direct[cols[c]] + sum_i jac[i] * tangent[i][c]
   (tangent (S, nl)). */
static inline void chain_row(double *row, const double *direct, const int *cols, const double *jac,
                             const double *tangent, int nl) {
    for (int c = 0; c < nl; c++) row[c] = direct[cols[c]];
    for (int i = 0; i < S; i++) {
        double ji = jac[i];
        if (ji != 0.0)
            for (int c = 0; c < nl; c++) row[c] += ji * tangent[i * nl + c];
    }
}

/* Outputs y and their derivatives dy (T, O, nt) w.r.t. the columns of th asked for (want (nt), nonzero: the P
   parameters, then the networks' weights; nt = P without networks; a column not asked for is 0) as forward
   sensitivities: the exact derivative of the same discrete map as forward_row, given the initial state's ds0
   (S, nt). The state's tangent carries only the nl columns asked for that reach it (state_columns); an output's
   derivative is its direct one plus the state's share in those. Where the input moves with some columns (dU
   (T, NI) its derivative w.r.t. the row's delay, dth (nt) the delay's w.r.t. each column; both NULL: none), their
   derivatives take the inputs' share too (input_share), at every stage and sample. */
static void tangent_row(int T, int nt, const double *U, const double *h, const double *th, const double *s0,
                        const double *ds0, const double *want, const double *dU, const double *dth, int nst,
                        const double *c, const double *A, const double *bw, int sub, double *y, double *dy) {
    const int s1 = DIM(S), n1 = DIM(nt);
    double K[nst * s1], Y[s1], FS[s1 * s1], g[DIM(O)], gs[DIM(O) * s1], buf[NB], FI[s1 * NI], GI[DIM(O) * NI];
    double st[s1], lo[s1], hi[s1], fl[s1], dlo[DIM(S * P)], dhi[DIM(S * P)], in[NI], din[NI];
    int *cols = malloc(sizeof(int) * n1);
    const int nl = state_columns(nt, ds0, want, dth, cols), l1 = DIM(nl);
    double *dK = malloc(sizeof(double) * nst * s1 * l1), *dY = malloc(sizeof(double) * s1 * l1);
    double *sig = malloc(sizeof(double) * s1 * l1); /* d(state)/d(th[cols]) (S, nl) */
    double *FT = malloc(sizeof(double) * s1 * n1), *gt = malloc(sizeof(double) * DIM(O) * n1);
    memset(K, 0, sizeof K);
    memset(dK, 0, sizeof(double) * nst * s1 * l1);
    for (int i = 0; i < S; i++) st[i] = s0[i];
    for (int i = 0; i < S; i++)
        for (int q = 0; q < nl; q++) sig[i * nl + q] = ds0[i * nt + cols[q]];
    if (HAS_BOUNDS) bounds(st, ZERO_IN, th, lo, hi, dlo, dhi);
    for (int k = 0; k < T; k++) {
        jac_full(out_jac, out_net_vjp, O, st, U + k * NI, th, nt, g, gs, gt, GI, buf);
        if (dU) input_share(O, nt, GI, dU + k * NI, dth, gt);
        for (int o = 0; o < O; o++) {
            double *row = dy + (k * O + o) * nt;
            y[k * O + o] = g[o];
            for (int p = 0; p < nt; p++) row[p] = want[p] != 0.0 ? gt[o * nt + p] : 0.0;
            for (int i = 0; i < S; i++) {
                double ji = gs[o * S + i];
                if (ji != 0.0)
                    for (int q = 0; q < nl; q++) row[cols[q]] += ji * sig[i * nl + q];
            }
        }
        if (k == T - 1) break;
        double hk = h[k] / sub;
        for (int m = 0; m < sub; m++) {
            for (int j = 0; j < nst; j++) { /* stage j: Y_j = s + hk sum_l A_jl K_l, K_j = f(Y_j); so the tangents */
                stage_state(st, K, j, hk, A, nst, Y);
                for (int i = 0; i < S; i++) {
                    double *dyi = dY + i * nl;
                    for (int q = 0; q < nl; q++) dyi[q] = sig[i * nl + q];
                    for (int l = 0; l < j; l++) {
                        double a = hk * A[j * nst + l];
                        if (a != 0.0) {
                            const double *dkl = dK + (l * s1 + i) * l1;
                            for (int q = 0; q < nl; q++) dyi[q] += a * dkl[q];
                        }
                    }
                }
                stage_input(U, k, (m + c[j]) / sub, in);
                jac_full(rhs_jac, rhs_net_vjp, S, Y, in, th, nt, K + j * s1, FS, FT, FI, buf);
                if (dU) {
                    stage_input(dU, k, (m + c[j]) / sub, din); /* the input's derivative, interpolated like it */
                    input_share(S, nt, FI, din, dth, FT);
                }
                for (int i = 0; i < S; i++)
                    chain_row(dK + (j * s1 + i) * l1, FT + i * nt, cols, FS + i * S, dY, nl);
            }
            for (int i = 0; i < S; i++) {
                double acc = 0.0;
                for (int j = 0; j < nst; j++) acc += bw[j] * K[j * s1 + i];
                st[i] += hk * acc;
                for (int q = 0; q < nl; q++) dY[q] = 0.0; /* (dY's row 0 as scratch: sum_j bw_j dK_j) */
                for (int j = 0; j < nst; j++) {
                    const double *dkj = dK + (j * s1 + i) * l1;
                    for (int q = 0; q < nl; q++) dY[q] += bw[j] * dkj[q];
                }
                for (int q = 0; q < nl; q++) sig[i * nl + q] += hk * dY[q];
            }
            if (HAS_BOUNDS) { /* a state held at a bound follows the bound (which no weight moves) */
                project(st, lo, hi, fl);
                for (int i = 0; i < S; i++)
                    if (fl[i] != 0.0)
                        for (int q = 0; q < nl; q++) {
                            int p = cols[q];
                            sig[i * nl + q] = p < P ? (fl[i] > 0 ? dhi[i * P + p] : dlo[i * P + p]) : 0.0;
                        }
            }
        }
    }
    free(cols);
    free(dK);
    free(dY);
    free(sig);
    free(FT);
    free(gt);
}
#endif /* HH_TANGENT */

#ifdef HH_BACKWARD
/* Exact adjoint of forward_row: accumulates dL/dth (NT), dL/dU (T, NI), dL/ds0 (S) from dL/dy (T, O) and
   dL/d(states at the samples) (T, S). */
static void backward_row(int T, int NT, const double *U, const double *h, const double *th, const double *states,
                         const double *gy, const double *gS, int nst, const double *c, const double *A,
                         const double *bw, int sub, double *gth, double *gU, double *gs0) {
    const int s1 = DIM(S), p1 = DIM(P);
    double lam[s1], g[DIM(O)], gs[DIM(O) * s1], gt[DIM(O) * p1], gi[DIM(O) * NI];
    double K[nst * s1], Y[s1], Yst[nst * s1], FS[nst * s1 * s1], FT[nst * s1 * p1], FI[nst * s1 * NI];
    double lamK[nst * s1], lamY[s1], UIN[nst * NI], gin[NI], st[s1];
    double lo[s1], hi[s1], dlo[s1 * p1], dhi[s1 * p1];
    double *sub_start = malloc(sizeof(double) * sub * s1);
    double *flags = malloc(sizeof(double) * sub * s1);
    double *buf = malloc(sizeof(double) * (nst + 1) * NB); /* the networks' layers per stage; the last: the sample */
    (void)NT;
    memset(K, 0, sizeof K);
    for (int i = 0; i < S; i++) lam[i] = 0.0;
    if (HAS_BOUNDS) bounds(states, ZERO_IN, th, lo, hi, dlo, dhi);
    for (int k = T - 1; k >= 0; k--) {
        const double *sk = states + k * S;
        /* output y_k = g(s_k, U_k, th) */
        out_jac(sk, U + k * NI, th, g, gs, gt, gi, buf + nst * NB);
        for (int o = 0; o < O; o++) {
            double w = gy[k * O + o];
            if (w != 0.0) {
                for (int i = 0; i < S; i++) lam[i] += gs[o * S + i] * w;
                for (int p = 0; p < P; p++) gth[p] += gt[o * P + p] * w;
                for (int q = 0; q < NI; q++) gU[k * NI + q] += gi[o * NI + q] * w;
            }
        }
        for (int i = 0; i < S; i++) lam[i] += gS[k * S + i]; /* the states' own cotangent (return_states) */
        if (NETS) { /* the networks' share of the output's adjoint */
            for (int q = 0; q < NI; q++) gin[q] = 0.0;
            out_net_vjp(sk, U + k * NI, th, gy + k * O, lam, gth, gin, buf + nst * NB);
            for (int q = 0; q < NI; q++) gU[k * NI + q] += gin[q];
        }
        if (k == 0) break;
        int kk = k - 1;
        double hk = h[kk] / sub;
        /* recover the start state of every sub-step of interval kk (one sub-step without bounds: the sample's) */
        for (int i = 0; i < S; i++) st[i] = states[kk * S + i];
        if (sub == 1 && !HAS_BOUNDS) {
            for (int i = 0; i < S; i++) sub_start[i] = st[i];
        } else {
            for (int m = 0; m < sub; m++) {
                for (int i = 0; i < S; i++) sub_start[m * s1 + i] = st[i];
                substep(kk, m, st, K, Y, hk, U, th, nst, c, A, bw, sub, buf);
                if (HAS_BOUNDS) project(st, lo, hi, flags + m * s1);
            }
        }
        for (int m = sub - 1; m >= 0; m--) {
            if (HAS_BOUNDS) { /* adjoint of the projection: a state held at a bound follows the bound */
                for (int i = 0; i < S; i++) {
                    double f = flags[m * s1 + i];
                    if (f != 0.0) {
                        for (int p = 0; p < P; p++) gth[p] += (f > 0 ? dhi[i * P + p] : dlo[i * P + p]) * lam[i];
                        lam[i] = 0.0;
                    }
                }
            }
            /* stages of sub-step m with their Jacobians */
            for (int j = 0; j < nst; j++) {
                stage_state(sub_start + m * s1, K, j, hk, A, nst, Yst + j * s1);
                stage_input(U, kk, (m + c[j]) / sub, UIN + j * NI);
                rhs_jac(Yst + j * s1, UIN + j * NI, th, K + j * s1, FS + j * s1 * s1, FT + j * s1 * p1,
                        FI + j * s1 * NI, buf + j * NB);
            }
            /* adjoint of s' = s + hk sum_j bw_j K_j, K_j = f(Y_j), Y_j = s + hk sum_l A_jl K_l */
            for (int j = 0; j < nst; j++)
                for (int i = 0; i < S; i++) lamK[j * s1 + i] = hk * bw[j] * lam[i];
            for (int j = nst - 1; j >= 0; j--) {
                double fr = (m + c[j]) / sub;
                const double *fs = FS + j * s1 * s1, *ft = FT + j * s1 * p1, *fi = FI + j * s1 * NI;
                const double *lk = lamK + j * s1;
                for (int i = 0; i < S; i++) {
                    double acc = 0.0;
                    for (int r = 0; r < S; r++) acc += fs[r * S + i] * lk[r];
                    lamY[i] = acc;
                }
                for (int p = 0; p < P; p++) {
                    double acc = 0.0;
                    for (int r = 0; r < S; r++) acc += ft[r * P + p] * lk[r];
                    gth[p] += acc;
                }
                for (int q = 0; q < NI; q++) {
                    double acc = 0.0;
                    for (int r = 0; r < S; r++) acc += fi[r * NI + q] * lk[r];
                    gU[kk * NI + q] += acc * (1.0 - fr);
                    gU[(kk + 1) * NI + q] += acc * fr;
                }
                if (NETS) { /* the networks' share: their weights, and through their inputs the state's adjoint */
                    for (int q = 0; q < NI; q++) gin[q] = 0.0;
                    rhs_net_vjp(Yst + j * s1, UIN + j * NI, th, lk, lamY, gth, gin, buf + j * NB);
                    for (int q = 0; q < NI; q++) {
                        gU[kk * NI + q] += gin[q] * (1.0 - fr);
                        gU[(kk + 1) * NI + q] += gin[q] * fr;
                    }
                }
                for (int l = 0; l < j; l++)
                    for (int i = 0; i < S; i++) lamK[l * s1 + i] += hk * A[j * nst + l] * lamY[i];
                for (int i = 0; i < S; i++) lam[i] += lamY[i];
            }
        }
    }
    for (int i = 0; i < S; i++) gs0[i] = lam[i];
    free(sub_start);
    free(flags);
    free(buf);
}
#endif /* HH_BACKWARD */

#ifdef HH_FORWARD
void hh_forward(long b0, long b1, long T, long NT, const double *U, const double *h, const double *th,
                const double *s0, long nst, const double *c, const double *A, const double *bw, long sub,
                double *states, double *y) {
    for (long b = b0; b < b1; b++) {
        double *thx = with_hoisted(th + b * NT, NT);
        forward_row(T, U + b * T * NI, h + b * (T - 1), thx, s0 + b * S, nst, c, A, bw, sub, states + b * T * S,
                    y + b * T * O);
        free(thx);
    }
}
#endif /* HH_FORWARD */

#ifdef HH_BACKWARD
void hh_backward(long b0, long b1, long T, long NT, const double *U, const double *h, const double *th,
                 const double *states, const double *gy, const double *gS, long nst, const double *c,
                 const double *A, const double *bw, long sub, double *gth, double *gU, double *gs0) {
    for (long b = b0; b < b1; b++) {
        double *thx = with_hoisted(th + b * NT, NT);
        backward_row(T, NT, U + b * T * NI, h + b * (T - 1), thx, states + b * T * S, gy + b * T * O,
                     gS + b * T * S, nst, c, A, bw, sub, gth + b * NT, gU + b * T * NI, gs0 + b * S);
        free(thx);
    }
}
#endif /* HH_BACKWARD */

#ifdef HH_TANGENT
void hh_tangent(long b0, long b1, long T, long NT, const double *U, const double *h, const double *th,
                const double *s0, const double *ds0, const double *want, const double *dU, const double *dth,
                long nst, const double *c, const double *A, const double *bw, long sub, double *y, double *dy) {
    for (long b = b0; b < b1; b++) {
        double *thx = with_hoisted(th + b * NT, NT);
        tangent_row(T, NT, U + b * T * NI, h + b * (T - 1), thx, s0 + b * S, ds0 + b * S * NT, want,
                    dU ? dU + b * T * NI : NULL, dth ? dth + b * NT : NULL, nst, c, A, bw, sub, y + b * T * O,
                    dy + b * T * O * NT);
        free(thx);
    }
}
#endif /* HH_TANGENT */
