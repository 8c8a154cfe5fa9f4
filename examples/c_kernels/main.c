/* Reuse the ancf_sym kernels from C: elastic force and tangent stiffness of one ANCF cable3d element.
 *
 * Calls two compiled kernels of the installed package (ancf_sym/_kernels/):
 *   cable3d_axial_green : U_a = 1/2 int EA eps^2 dx,  eps = (r_x.r_x - 1)/2,   p = [L, EA]
 *   cable3d_bending     : U_b = 1/2 int EI kappa^2 dx, kappa^2 = |r_x x r_xx|^2/|r_x|^6,   p = [L, EI]
 * Each kernel is (q, p) -> (energy, gradient, hessian), q = [r(0), r_x(0), r(L), r_x(L)] (12 entries, [m, -]).
 * The gradient dU/dq is the generalised elastic force the element exerts on its nodes with a minus sign
 * (internal force vector Q_e = dU/dq, as it enters M q'' + Q_e = Q); the Hessian is the tangent stiffness.
 *
 * Usage: cable3d_element                      (hard-coded state below)
 *        cable3d_element L EA EI q1 ... q12    (15 numbers)
 * Output (every number with %.17g, so it reads back exactly):
 *   energy_axial_green <U_a>
 *   energy_bending <U_b>
 *   gradient <12 numbers: dU/dq of U_a + U_b>
 *   hessian <i> <12 numbers: row i of d2U/dq2 of U_a + U_b>   (12 lines)
 *
 * Build: see README.md. The CasADi calling convention used here (read from the generated headers):
 *   <name>_work(&sz_arg, &sz_res, &sz_iw, &sz_w)   sizes of the pointer and work arrays the call needs,
 *   <name>_incref() / <name>_decref()              once around all use of the function,
 *   mem = <name>_checkout(); ... <name>_release(mem) around each call (thread-safe memory slot),
 *   <name>(arg, res, iw, w, mem)                   arg[i] -> input i, res[i] -> output i, returns 0 on success.
 * Inputs and outputs are dense here (checked through <name>_sparsity_in/out); matrices are column-major.
 */
#include <stdio.h>
#include <stdlib.h>

#include "cable3d_axial_green.h"
#include "cable3d_bending.h"

#define NQ 12
#define NP 2

typedef struct {
    const char *name;
    int (*eval)(const casadi_real **arg, casadi_real **res, casadi_int *iw, casadi_real *w, int mem);
    int (*work)(casadi_int *sz_arg, casadi_int *sz_res, casadi_int *sz_iw, casadi_int *sz_w);
    void (*incref)(void);
    void (*decref)(void);
    int (*checkout)(void);
    void (*release)(int mem);
    casadi_int (*n_in)(void);
    casadi_int (*n_out)(void);
    const casadi_int *(*sparsity_in)(casadi_int i);
    const casadi_int *(*sparsity_out)(casadi_int i);
} kernel_t;

#define KERNEL(n)                                                                                        \
    {#n, n, n##_work, n##_incref, n##_decref, n##_checkout, n##_release, n##_n_in, n##_n_out, n##_sparsity_in, \
     n##_sparsity_out}

/* Number of stored entries of a CasADi compressed-column sparsity pattern [nrow, ncol, colind..., row...];
 * the compact form [nrow, ncol, 1] means dense. */
static casadi_int nnz(const casadi_int *sp) {
    return sp[2] == 1 ? sp[0] * sp[1] : sp[2 + sp[1]]; /* a genuine colind starts with 0 */
}

static int is_dense(const casadi_int *sp, casadi_int nrow, casadi_int ncol) {
    return sp && sp[0] == nrow && sp[1] == ncol && nnz(sp) == nrow * ncol;
}

/* energy (1), gradient (NQ), hessian (NQ*NQ, column-major) of one kernel at (q, p). Returns 0 on success. */
static int evaluate(const kernel_t *k, const double *q, const double *p, double *energy, double *grad,
                    double *hess) {
    casadi_int sz_arg, sz_res, sz_iw, sz_w;
    int flag, mem;
    const casadi_real **arg;
    casadi_real **res, *w;
    casadi_int *iw;

    if (k->n_in() != 2 || k->n_out() != 3 || !is_dense(k->sparsity_in(0), NQ, 1) ||
        !is_dense(k->sparsity_in(1), NP, 1) || !is_dense(k->sparsity_out(0), 1, 1) ||
        !is_dense(k->sparsity_out(1), NQ, 1) || !is_dense(k->sparsity_out(2), NQ, NQ)) {
        fprintf(stderr, "%s: unexpected signature (want (q[%d], p[%d]) -> (1, %d, %dx%d), dense)\n", k->name, NQ,
                NP, NQ, NQ, NQ);
        return 1;
    }
    k->work(&sz_arg, &sz_res, &sz_iw, &sz_w);
    arg = malloc(sizeof *arg * (size_t)sz_arg);
    res = malloc(sizeof *res * (size_t)sz_res);
    iw = malloc(sizeof *iw * (size_t)(sz_iw > 0 ? sz_iw : 1));
    w = malloc(sizeof *w * (size_t)(sz_w > 0 ? sz_w : 1));
    if (!arg || !res || !iw || !w) {
        fprintf(stderr, "%s: out of memory\n", k->name);
        return 1;
    }
    arg[0] = q;
    arg[1] = p;
    res[0] = energy;
    res[1] = grad;
    res[2] = hess;
    mem = k->checkout();
    flag = k->eval(arg, res, iw, w, mem);
    k->release(mem);
    free(arg);
    free(res);
    free(iw);
    free(w);
    if (flag) fprintf(stderr, "%s: evaluation failed (flag %d)\n", k->name, flag);
    return flag;
}

static void print_vector(const char *label, const double *v, int n) {
    int i;
    printf("%s", label);
    for (i = 0; i < n; ++i) printf(" %.17g", v[i]);
    printf("\n");
}

int main(int argc, char **argv) {
    /* default: L = 1.2 m, EA = 1e4 N, EI = 25 N m^2; a curved, stretched, out-of-plane state */
    double L = 1.2, EA = 1.0e4, EI = 25.0;
    double q[NQ] = {0.1, -0.2, 0.05, /* r(0)   */
                    0.95, 0.30, -0.10, /* r_x(0) */
                    1.15, 0.35, 0.20, /* r(L)   */
                    0.85, -0.25, 0.40}; /* r_x(L) */
    double pa[NP], pb[NP], ea, eb, ga[NQ], gb[NQ], Ha[NQ * NQ], Hb[NQ * NQ], g[NQ], row[NQ];
    kernel_t axial = KERNEL(cable3d_axial_green), bending = KERNEL(cable3d_bending);
    int i, j, flag;

    if (argc == 1 + 3 + NQ) {
        double *dst[3 + NQ];
        dst[0] = &L;
        dst[1] = &EA;
        dst[2] = &EI;
        for (i = 0; i < NQ; ++i) dst[3 + i] = &q[i];
        for (i = 0; i < 3 + NQ; ++i) {
            char *end;
            *dst[i] = strtod(argv[1 + i], &end);
            if (end == argv[1 + i] || *end != '\0') {
                static const char *names[3] = {"L", "EA", "EI"};
                fprintf(stderr, "argument %d (%s) is not a number: '%s'\n", i + 1, i < 3 ? names[i] : "q",
                        argv[1 + i]);
                return 2;
            }
        }
    } else if (argc != 1) {
        fprintf(stderr, "usage: %s [L EA EI q1 ... q12]\n", argv[0]);
        return 2;
    }
    if (!(L > 0)) { /* the Python loader refuses this too; the C kernels do not check their inputs */
        fprintf(stderr, "L must be positive, got %g\n", L);
        return 2;
    }
    pa[0] = L;
    pa[1] = EA;
    pb[0] = L;
    pb[1] = EI;

    axial.incref();
    bending.incref();
    flag = evaluate(&axial, q, pa, &ea, ga, Ha) || evaluate(&bending, q, pb, &eb, gb, Hb);
    axial.decref();
    bending.decref();
    if (flag) return 1;

    printf("energy_axial_green %.17g\n", ea);
    printf("energy_bending %.17g\n", eb);
    for (i = 0; i < NQ; ++i) g[i] = ga[i] + gb[i];
    print_vector("gradient", g, NQ);
    for (i = 0; i < NQ; ++i) {
        char label[32];
        for (j = 0; j < NQ; ++j) row[j] = Ha[i + NQ * j] + Hb[i + NQ * j]; /* column-major */
        snprintf(label, sizeof label, "hessian %d", i);
        print_vector(label, row, NQ);
    }
    return 0;
}
