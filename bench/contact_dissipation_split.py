"""Where an untouched dissipative contact's time goes, per Newton iteration: the mapped damping/friction kernel
alone (40 cable2d elements, all pairs), the same kernel behind a per-element reach switch (casadi
Function.conditional: out of reach -> zeros, the kernel not evaluated) with 0, 4 and 40 elements in reach, and the
whole dissipation function of the step (the _rows kernel + scatter into df/dx and df/dv), for a
ground 10 m below and a drum (R = 1 m) 10 m below a 1 m rope at y = 0.05 m. CPU time, min over 5 x 300 calls.

Run: python bench/contact_dissipation_split.py
"""
from __future__ import annotations

import os
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import casadi as ca  # noqa: E402
import numpy as np  # noqa: E402

from ancf_sym import Material, Scene, Section, contact, kernels  # noqa: E402
from ancf_sym.model.assembly import Assembly  # noqa: E402
from ancf_sym.system.step_system import StepSystem  # noqa: E402

LAW = dict(stiffness=1e4, damping=3e4, mu=0.3, eps=1e-3)


def us(fn, *a, n: int = 300) -> float:
    best = np.inf
    for _ in range(5):
        t = time.process_time()
        for _ in range(n):
            fn(*a)
        best = min(best, (time.process_time() - t) / n)
    return best * 1e6


def main() -> None:
    for kind in ("ground", "drum"):
        sc = Scene(dim=2, gravity=(0.0, -9.81))
        sc.member("rope", [(0.0, 0.05), (1.0, 0.05)], 40, Material(E=2e9, density=1000.0), Section.circle(0.01))
        if kind == "ground":
            sc.contact_ground("rope", level=-10.0, **LAW)
        else:
            sc.contact_drum("rope", centre=(0.5, -10.0), radius=1.0, **LAW)
        asm = Assembly(sc)
        (element, effect, gauss, idx, P), = contact.dissipation_calls(asm.mesh)
        N, nd = idx.shape
        k = kernels.load(element, effect, None if gauss == 5 else gauss)
        Zs, Ps, ms = ca.MX.sym("Z", 2 * nd, N), ca.MX.sym("P", P.shape[1], N), ca.MX.sym("m", 1, N)
        full = ca.Function("full", [Zs, Ps], list(k.map(N)(Zs, Ps)))
        zero = ca.Function("zero", [ca.MX.sym("z", 2 * nd), ca.MX.sym("p", P.shape[1])],
                           [ca.MX(1, 1), ca.MX(2 * nd, 1), ca.MX(2 * nd, 2 * nd)])
        cond = ca.Function.conditional("reach", [zero], k)  # switch 0: out of reach (zeros), 1: the kernel
        cmap = ca.Function("cmap", [ms, Zs, Ps], list(cond.map(N)(ms, Zs, Ps)))
        Z, Pd = ca.DM(np.vstack([asm.x0[idx].T, np.zeros((nd, N))])), ca.DM(P.T)
        ref = full(Z, Pd)
        print(f"{kind}: mapped kernel, all {N} pairs: {us(full, Z, Pd):.1f} us")
        rows = ca.Function("rows", [Zs, Ps], list(kernels.load_rows(element, effect, None if gauss == 5 else gauss)
                                                  .map(N)(Zs, Ps)))
        print(f"{kind}: mapped _rows kernel (force, [df/dq, df/dv]), all {N} pairs: {us(rows, Z, Pd):.1f} us")
        for on in (0, 4, N):
            m = np.zeros((1, N))
            m[0, :on] = 1
            out = cmap(ca.DM(m), Z, Pd)
            same = all(np.array_equal(np.asarray(a), np.asarray(b)) for a, b in zip(out, ref))
            print(f"{kind}: behind the reach switch, {on:2d} of {N} in reach: {us(cmap, ca.DM(m), Z, Pd):.1f} us"
                  f" (outputs bitwise equal to all pairs: {same})")
        S = StepSystem(asm)
        x, v = S.reduce(asm.x0), np.zeros(S.nf)
        print(f"{kind}: step's dissipation function (f, df/dx, df/dv): {us(S.damp_f, x, v):.1f} us; force alone "
              f"{us(S.damp_force_f, x, v):.1f} us; linear solver {S.linsol}")


if __name__ == "__main__":
    main()
