"""What the fused decoupled-strain elastic kernel costs against the two kernels it replaces.

A decoupled-strain cable with bending called two kernels per element (axial_decoupled[_biot] and bending); the
internal effect elastic_decoupled[_biot] sums them in one structured kernel. Printed, at Gauss 5:
- SX instructions of each kernel (the expanded SX function, `n_instructions()`), the two unfused ones summed;
- the batched (SIMD, 4 lanes) kernels on 8 elements: time per evaluation of the two unfused kernels against the
  fused one, through CasADi's buffer interface (min / median over repeats of an inner loop);
- a dynamics run of a decoupled cable (paper 000's beam released horizontal, the zhang_pendulum study's scene,
  generalized-alpha, dt = 1e-3 s, 1 s): time loop per step with the fused step graph and with one kernel call per
  term (StepSystem fuse=False), runs interleaved.

    python bench/decoupled_fused.py [--repeats 30] [--n 6] [--dyn-repeats 5]

Before the fused kernel existed, the same script printed the unfused figures only (it skips what is missing).
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from ancf_sym import kernels, registry
from ancf_sym.util.casadi_buffers import bind

ELEMENTS = ("cable2d", "cable3d")
PAIRS = (("axial_decoupled", "elastic_decoupled"), ("axial_decoupled_biot", "elastic_decoupled_biot"))


def _instructions(element: str, effect: str) -> int:
    from ancf_sym.codegen import definitions
    return definitions.kernel(element, effect, registry.DEFAULT_GAUSS).n_instructions()


def _state(element: str, n: int, rng) -> tuple[np.ndarray, np.ndarray]:
    dim = registry.ELEMENTS[element].dim
    X = []
    for _ in range(n):
        t0, t1 = np.eye(dim)[0] * 1.05 + 0.2 * rng.standard_normal(dim), np.eye(dim)[0] + 0.2 * rng.standard_normal(dim)
        X.append(np.r_[np.zeros(dim), t0, 0.5 * np.eye(dim)[0] + 0.05 * rng.standard_normal(dim), t1])
    return np.array(X), rng.uniform(0.9, 1.1, (n, 1)) * np.array([0.5, 1.6e6, 10.0])


def _timer(f, X, P) -> callable:
    nd, n_p = X.shape[1], P.shape[1]
    Xb, Pb = np.ascontiguousarray(X), np.ascontiguousarray(P[:, :n_p])
    outs = [np.zeros(f.nnz_out(i)) for i in range(f.n_out())]
    buf, ev = bind(f, (Xb, Pb), outs)
    return buf, ev


def _loops(variants: list, inner: int, repeats: int) -> list[tuple[float, float]]:
    """(min, median) seconds per evaluation of each variant (a list of evaluate calls), rounds interleaved."""
    times = [[] for _ in variants]
    for _ in range(repeats):
        for calls, t in zip(variants, times):
            t0 = time.perf_counter()
            for _ in range(inner):
                for ev in calls:
                    ev()
            t.append((time.perf_counter() - t0) / inner)
    return [(min(t), float(np.median(t))) for t in times]


def kernels_part(repeats: int) -> None:
    rng = np.random.default_rng(3)
    lanes = registry.BATCH_LANES
    for element in ELEMENTS:
        X, P = _state(element, 2 * lanes, rng)
        for axial, fused in PAIRS:
            n_ax, n_b = _instructions(element, axial), _instructions(element, "bending")
            line = f"{element} {axial} + bending: SX instructions {n_ax} + {n_b} = {n_ax + n_b}"
            fa = kernels.load_batch(element, axial).map(2)
            fb = kernels.load_batch(element, "bending").map(2)
            keep = [_timer(fa, X, P[:, [0, 1]]), _timer(fb, X, P[:, [0, 2]])]
            variants = [[k[1] for k in keep]]
            if (element, fused) in registry.EFFECTS:
                n_f = _instructions(element, fused)
                keep.append(_timer(kernels.load_batch(element, fused).map(2), X, P))
                variants.append([keep[-1][1]])
                line += f"; {fused} {n_f} ({n_f / (n_ax + n_b):.2f}x)"
            t = _loops(variants, 1000, repeats)
            print(line)
            out = f"  batched, 8 elements, us per evaluation (min / median): two kernels {t[0][0] * 1e6:.2f} / " \
                  f"{t[0][1] * 1e6:.2f}"
            if len(t) > 1:
                out += f", fused {t[1][0] * 1e6:.2f} / {t[1][1] * 1e6:.2f} (ratio of minima {t[1][0] / t[0][0]:.2f})"
            print(out)


def dynamics_part(n: int, repeats: int) -> None:
    from ancf_sym.model.assembly import Assembly
    from ancf_sym.dynamics import DynamicOptions, StepSystem, simulate
    from ancf_sym.study.dynamics_studies import zhang_scene

    opts = DynamicOptions(dt=1e-3, t_end=1.0, integrator="generalized_alpha")
    best = {True: [], False: []}
    systems = {}
    for fuse in (True, False):
        asm = Assembly(zhang_scene(n))
        systems[fuse] = (asm, StepSystem(asm, None, fuse=fuse))
        simulate(asm, opts, system=systems[fuse][1])  # warm: graphs built and compiled calls bound
    for _ in range(repeats):
        for fuse in (True, False):
            asm, S = systems[fuse]
            r = simulate(asm, opts, system=S)
            assert r.status == "completed", r.message
            best[fuse].append(r.wall_s / r.steps)
    fused = any(ft.fused for ft in systems[True][1].force_terms)
    print(f"dynamics, zhang_pendulum scene, decoupled n = {n}, generalized-alpha dt = 1e-3 s, 1 s "
          f"({'fused kernel' if fused else 'no fused kernel: both runs call two kernels'}); time loop per step, "
          f"ms (min / median over {repeats}): fuse on {min(best[True]) * 1e3:.4f} / {np.median(best[True]) * 1e3:.4f}, "
          f"off {min(best[False]) * 1e3:.4f} / {np.median(best[False]) * 1e3:.4f} "
          f"(ratio of minima {min(best[True]) / min(best[False]):.2f})")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=30)
    ap.add_argument("--n", type=int, default=6, help="elements of the dynamics scene")
    ap.add_argument("--dyn-repeats", type=int, default=5)
    a = ap.parse_args()
    kernels_part(a.repeats)
    dynamics_part(a.n, a.dyn_repeats)


if __name__ == "__main__":
    main()
