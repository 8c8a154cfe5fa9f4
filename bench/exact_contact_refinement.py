"""Exact contact statics under refinement: the slack rope on the ground (EA 1e7 N, 5 N/m, 12 m between pins at
(0, 1.5) and (10, 1.5)) against the closed form (two elastic catenaries with their vertex at the touchdown), with
the decoupled and the coupled Biot strain, and the slack rope over a drum; per n: status, stability, the relative
error of the horizontal force H, the potential, the wall time of a new problem's solve (its chain of coarser
meshes included) and the IPOPT iterations on this mesh alone (from the coarser mesh's solution where there is one). The scenes and the closed form are those of tests/contact/test_contact_exact_refinement.py.

Run: python bench/exact_contact_refinement.py [n ...]   (default 32 64 128 256 512; from the repository root)
"""
from __future__ import annotations

import os
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests"))

from test_contact_exact_refinement import H_REF, _H, drum_scene, rope_scene  # noqa: E402

from ancf_sym import solve_static  # noqa: E402


def main(sizes: list[int]) -> None:
    print(f"closed form H = {H_REF:.10g} N")
    print(f"{'case':<18}{'n':>5}  {'status':<26}{'stable':>7}{'H error':>12}{'potential [J]':>18}{'time [s]':>10}{'its':>6}")
    for case, make in (("ground decoupled", lambda n: rope_scene(n)), ("ground biot", lambda n: rope_scene(n, "biot")),
                       ("drum decoupled", drum_scene)):
        for n in sizes:
            t0 = time.perf_counter()
            r = solve_static(make(n))
            dt = time.perf_counter() - t0
            err = f"{_H(r) / H_REF - 1:+.2e}" if r.success and case.startswith("ground") else "-"
            pot = f"{r.potential:.10f}" if r.success else "-"
            its = sum(a["iterations"] for a in r.attempts if a["method"] != "coarse mesh")
            print(f"{case:<18}{n:>5}  {r.status:<26}{str(r.stable):>7}{err:>12}{pot:>18}{dt:>10.2f}{its:>6}", flush=True)


if __name__ == "__main__":
    main([int(a) for a in sys.argv[1:]] or [32, 64, 128, 256, 512])
