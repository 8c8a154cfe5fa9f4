/* The kernel Newton loop of statics (ancf_sym.statics_newton.KernelNewton) as one call: every iteration's kernel
 * calls, scatter onto the free coordinates and LAPACK's band, banded Cholesky (or the banded LU and the diagonal
 * shifts where the tangent is not positive definite), and the convergence, stall, round-off and divergence tests;
 * asked to, a converged run then evaluates its answer (potential, and the stability check's shifted Cholesky).
 *
 * Hand-written, not generated. It links to nothing: the compiled kernels (CasADi's calling convention), LAPACK
 * (the pointers SciPy exports in scipy.linalg.cython_lapack) and Python's signal check come as function pointers,
 * bound once per loop by ancf_sym.newton_loop. The operations are the Python loop's, in the same order (the same
 * LAPACK calls; scatters summed in index order as numpy's bincount does; sums pairwise as numpy's sum does), so
 * the two loops take the same steps up to the last bits of a sum. Read statics_newton.py for the method and why.
 *
 * Compiled without floating-point contraction (-ffp-contract=off): an FMA would round differently from numpy. */
#include <math.h>
#include <string.h>
#include <float.h>

typedef long long ll;
typedef int (*kernel_fn)(const double **arg, double **res, ll *iw, double *w, int mem);
typedef void (*dpbtrf_fn)(char *uplo, int *n, int *kd, double *ab, int *ldab, int *info);
typedef void (*dpbtrs_fn)(char *uplo, int *n, int *kd, int *nrhs, double *ab, int *ldab, double *b, int *ldb,
                          int *info);
typedef void (*dgbsv_fn)(int *n, int *kl, int *ku, int *nrhs, double *ab, int *ldab, int *ipiv, double *b, int *ldb,
                         int *info);
typedef int (*signals_fn)(void);

/* constants of statics_newton.py (passed in, one home for each) */
typedef struct {
    double stall, round_off, shift, shift_max, shift_below, wild;
    ll stall_count, no_progress;
} nl_constants;

/* one mapped kernel call (ReducedEvaluation.calls): N elements (a whole number of lanes), nd inputs, np params */
typedef struct {
    kernel_fn f;
    ll lanes, N, nd, np, nlocal;
    const ll *idx;           /* N x nd: each input's coordinate in the scene */
    double *X;               /* N x nd: the inputs (the evaluation's own buffer) */
    const double *P;         /* N x np: parameters */
    double *E, *G, *H;       /* outputs: N, N x nd, N x nd x nd */
    const ll *ldst, *lsrc;   /* element-local positions: X[:, ldst] -= X[:, lsrc] (nlocal columns) */
    const double **arg;      /* the kernel's work arrays (its <name>_work sizes) */
    double **res;
    ll *iw;
    double *w;
} nl_term;

typedef struct {
    ll nf, n, bw, nterms;
    nl_term *terms;
    /* the reduction: x_full[i] = (gather[i] < nf ? x[gather[i]] : 0) + c[i]; x = x_full[roots] */
    const ll *gather, *roots;
    const double *c, *f_lin, *f_lin_full, *scale;
    double span;
    /* the evaluation's sums: energy over E[real] (real NULL: all of E), g by gpos, the band by hband */
    const double *E, *G, *H;
    const ll *real, *gpos, *hband;
    ll ne, nreal, ng, nh, sum_block;
    /* work: g (nf + 1), band (bw + 1) x nf + 1 row-major as ReducedEvaluation.band, ab / fac column-major,
       lu (3 bw + 1) x nf, vectors of nf and n, the LU's pivots */
    double *g, *band, *ab, *fac, *lu, *d, *r, *sol, *dz_try, *xt, *tmp;
    double *x, *dz, *p, *norms, *xfull, *xtry;
    int *ipiv;
    dpbtrf_fn dpbtrf;
    dpbtrs_fn dpbtrs;
    dgbsv_fn dgbsv;
    signals_fn check_signals;  /* PyErr_CheckSignals (with the GIL held), or NULL */
    nl_constants k;
} nl_problem;

/* one solve: inputs, then outputs */
typedef struct {
    const double *x0;        /* start, full coordinates */
    double tol, work, load, max_step;
    double finish;           /* > 0: after convergence, evaluate at the answer: its potential and whether its tangent
                                + finish x max |K_ii| I is positive definite (KernelNewton.positive_definite) */
    ll max_iter;
    double *hist;            /* 2 x max_iter: (increment, decrement) per iteration */
    double *x_out;           /* full coordinates after the last applied update */
    double *x_eval;          /* where the kernels were evaluated last */
    ll status, iterations, nhist;
    ll evaluations, indefinite, shifted;  /* kernel evaluations, tangents not positive definite, shifted steps */
    ll stable;               /* the finish's test: 1 positive definite, 0 not, -1 not done (or a zero diagonal) */
    double inc, dec, floor, energy, mu, prev_inc, ev_energy;
    double potential;        /* the finish's potential at the answer (NaN: not done) */
} nl_run;

enum { NL_CONVERGED, NL_ROUND_OFF, NL_STALLED, NL_DIVERGED, NL_NOT_FINITE, NL_MAX_ITER, NL_SINGULAR,
       NL_INTERRUPTED };

/* numpy's pairwise summation (pairwise_sum_DOUBLE), the order np.sum adds a contiguous array in */
static double pairwise(const double *a, ll n)
{
    if (n < 8) {
        double res = 0.;
        for (ll i = 0; i < n; i++) res += a[i];
        return res;
    }
    if (n <= 128) {
        double r[8], res;
        ll i;
        for (int j = 0; j < 8; j++) r[j] = a[j];
        for (i = 8; i < n - (n % 8); i += 8)
            for (int j = 0; j < 8; j++) r[j] += a[i + j];
        res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]));
        for (; i < n; i++) res += a[i];
        return res;
    }
    ll n2 = n / 2;
    n2 -= n2 % 8;
    return pairwise(a, n2) + pairwise(a + n2, n - n2);
}

/* np.sum of a contiguous float64 array: the identity 0 plus the pairwise sums of blocks of `block` entries (numpy's
   buffer size where its reduction iterates in buffered chunks, as numpy 1.x does; 0: one block) */
double nl_sum(const double *a, ll n, ll block)
{
    double out = 0.;
    if (block <= 0) block = n > 0 ? n : 1;
    for (ll i = 0; i < n; i += block) out += pairwise(a + i, n - i < block ? n - i : block);
    return out;
}

/* max |a[i] / s[i]| (s NULL: max |a[i]|), NaN if any is NaN, as numpy's max */
static double amax(const double *a, const double *s, ll n, double start)
{
    double m = start;
    for (ll i = 0; i < n; i++) {
        double v = s ? fabs(a[i] / s[i]) : fabs(a[i]);
        if (v > m || isnan(v)) m = v;
        if (isnan(m)) return m;
    }
    return m;
}

/* a . b as statics_newton._dot: the products, then their pairwise sum */
static double dot(const nl_problem *P, const double *a, const double *b, ll n)
{
    for (ll i = 0; i < n; i++) P->tmp[i] = a[i] * b[i];
    return nl_sum(P->tmp, n, P->sum_block);
}

static void full(const nl_problem *P, const double *x, double *out)
{
    for (ll i = 0; i < P->n; i++) {
        ll k = P->gather[i];
        out[i] = (k < P->nf ? x[k] : 0.0) + P->c[i];
    }
}

/* ReducedEvaluation.evaluate without penalties: kernels at xf, energy returned, g (nf + 1 entries) summed */
static double evaluate(const nl_problem *P, nl_run *R, const double *xf)
{
    R->evaluations++;
    for (ll t = 0; t < P->nterms; t++) {
        const nl_term *T = &P->terms[t];
        ll nd = T->nd, N = T->N;
        for (ll e = 0; e < N; e++) {
            double *X = T->X + e * nd;
            const ll *idx = T->idx + e * nd;
            for (ll a = 0; a < nd; a++) X[a] = xf[idx[a]];
            if (T->nlocal) {  /* both columns read before any is written, as numpy's fancy-indexed -= */
                double v[64];
                for (ll a = 0; a < T->nlocal; a++) v[a] = X[T->ldst[a]] - X[T->lsrc[a]];
                for (ll a = 0; a < T->nlocal; a++) X[T->ldst[a]] = v[a];
            }
        }
        ll L = T->lanes;
        for (ll b = 0; b < N / L; b++) {
            T->arg[0] = T->X + b * L * nd;
            T->arg[1] = T->P + b * L * T->np;
            T->res[0] = T->E + b * L;
            T->res[1] = T->G + b * L * nd;
            T->res[2] = T->H + b * L * nd * nd;
            T->f(T->arg, T->res, T->iw, T->w, 0);
        }
    }
    double energy;
    if (P->real) {
        for (ll i = 0; i < P->nreal; i++) P->tmp[i] = P->E[P->real[i]];
        energy = nl_sum(P->tmp, P->nreal, P->sum_block);
    } else {
        energy = nl_sum(P->E, P->ne, P->sum_block);
    }
    memset(P->g, 0, (size_t)(P->nf + 1) * sizeof(double));
    for (ll i = 0; i < P->ng; i++) P->g[P->gpos[i]] += P->G[i];
    return energy;
}

/* ReducedEvaluation.band, then into LAPACK's column-major storage ab[j * (bw + 1) + bw + i - j] */
static void band(const nl_problem *P)
{
    ll nf = P->nf, w = P->bw + 1, size = w * nf;
    memset(P->band, 0, (size_t)(size + 1) * sizeof(double));
    for (ll i = 0; i < P->nh; i++) P->band[P->hband[i]] += P->H[i];
    for (ll row = 0; row < w; row++)
        for (ll j = 0; j < nf; j++) P->ab[j * w + row] = P->band[row * nf + j];
}

/* max |K_jj| over the band's diagonal (ab's last row), NaN if any is NaN */
static double diagonal_max(const nl_problem *P)
{
    ll w = P->bw + 1;
    for (ll j = 0; j < P->nf; j++) P->tmp[j] = P->ab[j * w + P->bw];
    return amax(P->tmp, NULL, P->nf, 0.0);
}

/* banded Cholesky of ab + shift diag (shift NULL: none) into fac; the LAPACK info */
static int factor(const nl_problem *P, const double *shift)
{
    int n = (int)P->nf, kd = (int)P->bw, ldab = kd + 1, info = 0;
    char uplo = 'U';
    ll w = P->bw + 1;
    memcpy(P->fac, P->ab, (size_t)(w * P->nf) * sizeof(double));
    if (shift)
        for (ll j = 0; j < P->nf; j++) P->fac[j * w + P->bw] += shift[j];
    P->dpbtrf(&uplo, &n, &kd, P->fac, &ldab, &info);
    return info;
}

/* factor(shift) and the solve of -sol = K^-1 r into out; the LAPACK info */
static int cholesky_step(const nl_problem *P, const double *shift, double *out)
{
    int n = (int)P->nf, kd = (int)P->bw, ldab = kd + 1, nrhs = 1, info = factor(P, shift);
    char uplo = 'U';
    if (info != 0) return info;
    memcpy(P->sol, P->r, (size_t)P->nf * sizeof(double));
    P->dpbtrs(&uplo, &n, &kd, &nrhs, P->fac, &ldab, P->sol, &n, &info);
    for (ll j = 0; j < P->nf; j++) out[j] = -P->sol[j];
    return info;
}

/* statics_newton._banded_lu_solve: -K^-1 r by dgbsv on the full band (K's lower band mirrored), NaN if singular */
static void lu_step(const nl_problem *P, double *out)
{
    ll bw = P->bw, nf = P->nf, ld = 3 * bw + 1, w = bw + 1;
    memset(P->lu, 0, (size_t)(ld * nf) * sizeof(double));
    for (ll j = 0; j < nf; j++) {
        for (ll row = 0; row <= bw; row++) P->lu[j * ld + bw + row] = P->ab[j * w + row];
        for (ll d = 1; d <= bw && j + d < nf; d++)  /* K[j + d, j] = K[j, j + d] = ab[bw - d, j + d] */
            P->lu[j * ld + 2 * bw + d] = P->ab[(j + d) * w + bw - d];
    }
    int n = (int)nf, kl = (int)bw, ku = (int)bw, nrhs = 1, ldab = (int)ld, info = 0;
    memcpy(P->sol, P->r, (size_t)nf * sizeof(double));
    P->dgbsv(&n, &kl, &ku, &nrhs, P->lu, &ldab, P->ipiv, P->sol, &n, &info);
    for (ll j = 0; j < nf; j++) out[j] = info == 0 ? -P->sol[j] : -NAN;
}

/* potential at full coordinates xf: the kernels' energy minus the load's work */
static double potential(const nl_problem *P, nl_run *R, const double *xf, double load, double *ev_energy)
{
    *ev_energy = evaluate(P, R, xf);
    return *ev_energy - load * dot(P, P->f_lin_full, xf, P->n);
}

static void trial_point(const nl_problem *P, const double *dz)
{
    for (ll k = 0; k < P->nf; k++) P->xt[k] = P->x[k] + dz[k];
    full(P, P->xt, P->xtry);
}

/* KernelNewton._shifted_step: (K + mu D) dz = -r for mu from the last good shift / 10 up, until it goes downhill */
static int shifted_step(const nl_problem *P, nl_run *R, int *trial, const double **last)
{
    ll nf = P->nf, w = P->bw + 1;
    double dmax = diagonal_max(P);
    for (ll j = 0; j < nf; j++) P->d[j] = fabs(P->ab[j * w + P->bw]) + DBL_EPSILON * dmax;
    double mu = P->k.shift > R->mu * 0.1 ? P->k.shift : R->mu * 0.1;
    while (mu <= P->k.shift_max) {
        for (ll j = 0; j < nf; j++) P->tmp[j] = mu * P->d[j];
        if (cholesky_step(P, P->tmp, P->dz_try) == 0) {
            trial_point(P, P->dz_try);
            *last = P->xtry;
            if (potential(P, R, P->xtry, R->load, &R->ev_energy) < R->energy) {
                R->shifted++;
                memcpy(P->dz, P->dz_try, (size_t)nf * sizeof(double));
                R->mu = mu;
                *trial = 1;
                return 1;
            }
        }
        mu *= 10.0;
    }
    return 0;
}

/* KernelNewton._eval: the update dz and the norms (max|r|, 0, increment, -r . dz, max|K_ii|); *last: the point
 * the kernels were evaluated at last. NL_SINGULAR where the Python loop would turn to a sparse factorisation. */
static int iteration(const nl_problem *P, nl_run *R, int *trial, const double **last)
{
    ll nf = P->nf;
    full(P, P->x, P->xfull);
    int reuse = *trial;
    for (ll i = 0; reuse && i < P->n; i++)
        if (!(P->xfull[i] == P->xtry[i])) reuse = 0;
    *trial = 0;
    if (!reuse)  /* (else the last step was accepted on its potential: the kernels were evaluated there already) */
        R->ev_energy = evaluate(P, R, P->xfull);
    *last = P->xfull;  /* (equal to the trial point where reused) */
    for (ll k = 0; k < nf; k++) P->r[k] = P->g[k] + P->p[k];
    band(P);
    double kmax = diagonal_max(P);
    int done = 0;
    if (cholesky_step(P, NULL, P->dz) == 0) {
        done = 1;
    } else {  /* not positive definite: the plain step by the banded LU first */
        R->indefinite++;
        lu_step(P, P->dz);
        done = 1;
        for (ll k = 0; k < nf; k++)
            if (!isfinite(P->dz[k])) { done = 0; break; }
        if (R->prev_inc > P->k.shift_below && !(amax(P->dz, P->scale, nf, 0.0) <= P->k.shift_below)) {
            R->energy = R->ev_energy - R->load * dot(P, P->f_lin_full, P->xfull, P->n);
            trial_point(P, P->dz);
            int downhill = 0;
            if (done) {  /* (its potential only for a finite step) */
                *last = P->xtry;
                downhill = potential(P, R, P->xtry, R->load, &R->ev_energy) < R->energy;
            }
            if (downhill)
                *trial = 1;
            else
                done = shifted_step(P, R, trial, last) || done;
        }
    }
    if (!done) return NL_SINGULAR;
    P->norms[0] = amax(P->r, NULL, nf, 0.0);
    P->norms[1] = 0.0;
    P->norms[2] = amax(P->dz, P->scale, nf, 0.0);
    P->norms[3] = -dot(P, P->r, P->dz, nf);
    P->norms[4] = kmax;
    R->prev_inc = P->norms[2];
    return 0;
}

/* NewtonStatics.solve with KernelNewton's iteration. The run's status and figures in R; returns R->status. */
int nl_solve(const nl_problem *P, nl_run *R)
{
    ll nf = P->nf;
    const nl_constants *K = &P->k;
    for (ll k = 0; k < nf; k++) P->x[k] = R->x0[P->roots[k]];
    for (ll k = 0; k < nf; k++) P->p[k] = (-R->load) * P->f_lin[k];
    double W = DBL_MIN > R->work ? DBL_MIN : R->work;
    ll status = NL_MAX_ITER, stall = 0, it, nh = 0, best_at = 0;
    double inc = INFINITY, dec = INFINITY, best = INFINITY, floor = 0.0;
    int trial = 0;
    const double *last = NULL;
    R->mu = 0.0;
    R->prev_inc = INFINITY;
    R->evaluations = R->indefinite = R->shifted = 0;
    for (it = 1; it <= R->max_iter; it++) {
        if (P->check_signals && P->check_signals() != 0) {  /* Ctrl-C between two iterations, as in Python */
            status = NL_INTERRUPTED;
            break;
        }
        for (int j = 0; j < 5; j++) P->norms[j] = NAN;
        if (iteration(P, R, &trial, &last) == NL_SINGULAR) {
            status = NL_SINGULAR;
            break;
        }
        double rq = P->norms[0], kmax = P->norms[4];
        inc = P->norms[2];
        floor = DBL_EPSILON * kmax * P->span;
        dec = fabs(P->norms[3]) / W;
        if (!(isfinite(inc) && isfinite(rq) && isfinite(dec))) {
            status = NL_NOT_FINITE;
            it -= 1;
            break;
        }
        if (inc > R->max_step) {  /* a step longer than max_step structure lengths is cut back along its direction */
            double s = R->max_step / inc;
            for (ll k = 0; k < nf; k++) P->dz[k] *= s;
            dec = dec * s;
            inc = R->max_step;
        }
        for (ll k = 0; k < nf; k++) P->x[k] += P->dz[k];
        R->hist[2 * nh] = inc;
        R->hist[2 * nh + 1] = dec;
        nh++;
        if (inc < best) {
            best = inc;
            best_at = it;
        }
        if (inc <= R->tol && dec <= R->tol) { status = NL_CONVERGED; break; }
        if (inc > K->wild) { status = NL_DIVERGED; break; }
        if (nh > 1) {
            stall = inc > K->stall * R->hist[2 * (nh - 2)] ? stall + 1 : 0;
            if (R->hist[2 * (nh - 1)] > 1e8 * R->hist[0] + 1e8) { status = NL_DIVERGED; break; }
            if (stall >= K->stall_count && inc < 1e-3 && rq <= K->round_off * floor) { status = NL_ROUND_OFF; break; }
            if (stall >= 2 * K->stall_count || it - best_at > K->no_progress) { status = NL_STALLED; break; }
        }
    }
    if (status == NL_MAX_ITER) it = R->max_iter;  /* ran out (every break sets another status): Python's loop
                                                   variable keeps its last value, 0 without any */
    full(P, P->x, R->x_out);
    R->stable = -1;
    R->potential = NAN;
    if (status == NL_CONVERGED && R->finish > 0) {  /* the answer's potential and tangent: no second pass from Python */
        R->potential = potential(P, R, R->x_out, R->load, &R->ev_energy);
        last = R->x_out;
        band(P);
        double hmax = diagonal_max(P);
        if (hmax > 0) {
            for (ll j = 0; j < nf; j++) P->tmp[j] = R->finish * hmax;
            R->stable = factor(P, P->tmp) == 0;
        }
    }
    if (last) memcpy(R->x_eval, last, (size_t)P->n * sizeof(double));
    R->status = status;
    R->iterations = it;
    R->nhist = nh;
    R->inc = inc;
    R->dec = dec;
    R->floor = it ? floor : 0.0;
    return (int)status;
}
