"""beam3d under mesh refinement: angled frames (rigid joint, bent member), the frame normal to its plane of
tests/statics/test_beam_locking.py and the end-moment case, both methods.

Prints the relative tip error of the angled frames of tests/statics/test_frames_refinement.py (two members joined by `rigid`
or one bent member; load in the frame's plane or normal to it) against linear frame theory (the continuum's with its
transverse shear), the same for the frame normal to its plane and, for the end moment, the tip distance
(in L) from the quarter circle and from each form's own limit (extensible elastica; continuum uniform bending),
plus the elastic line's end-section turn past the tangent. The cases and references are those of
tests/statics/test_beam_locking.py. Usage: python bench/beam3d_refinement.py [--max-n 64]
"""
from __future__ import annotations

import argparse
import pathlib
import sys

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "tests"))
from test_frames_refinement import frame_error  # noqa: E402
from test_beam_locking import (B, E, H, IY, IZ, L, METHODS, SEC, _continuum_uniform_bending_tip,  # noqa: E402
                               _extensible_elastica_tip, _frame, _member)

from ancf_sym import Scene, solve_static  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--max-n", type=int, default=64)
    ap.add_argument("--frames-only", action="store_true")
    args = ap.parse_args()
    for bent in (False, True):
        for load in ("in_plane", "normal"):
            for method in METHODS:
                errs = [frame_error(method, n, load, bent) for n in (16, 64, 256)]
                print(f"angled frame {'bent member' if bent else 'two members'} {load:8s} {method:12s}",
                      "  ".join(f"n={n}: {e:+.2e}" for n, e in zip((16, 64, 256), errs)), flush=True)
    if args.frames_only:
        return
    ns = [n for n in (8, 16, 32, 64, 128, 256) if n <= args.max_n]
    nu, P, a, c = 0.3, 100.0, 0.5, 0.5
    G = E / (2 * (1 + nu))
    ref = P * a**3 / (3 * E * IY) + P * c**2 * a / (G * SEC.J) + P * c**3 / (3 * E * IY)
    for method in METHODS:
        errs = [solve_static(_frame(method, n, nu, P, a, c)).nodes("m2")[-1][2] / ref - 1 for n in ns]
        print(f"frame {method:12s}", "  ".join(f"n={n}: {e:+.2e}" for n, e in zip(ns, errs)), flush=True)
    M = E * IZ * np.pi / (2 * L)
    R = 2 * L / np.pi
    for method in METHODS:
        own = (_extensible_elastica_tip(M, E * IZ, E * B * H, L) if method == "elastic_line"
               else _continuum_uniform_bending_tip(M, nu, L))
        for n in ns:
            s = Scene(dim=3, gravity=(0.0, 0.0, 0.0))
            _member(s, "beam", [(0, 0, 0), (L, 0, 0)], n, method, nu, (0, 1, 0))
            s.clamp("beam", at="start")
            s.moment("beam", "end", (0.0, 0.0, M))
            r = solve_static(s)
            tip = r.nodes("beam")[-1]
            g = r.assembly.member_coordinates(r.x, "beam")[-1]
            turn = np.arctan2(-g[6], g[7]) - np.arctan2(g[4], g[3])
            print(f"end moment {method:12s} n={n:3d}: quarter circle {np.linalg.norm(tip - [R, R, 0]) / L:.2e} L, "
                  f"own limit {np.linalg.norm(tip - own) / L:.2e} L, section turn past tangent {turn:+.1e} rad, "
                  f"stable {r.stable}", flush=True)


if __name__ == "__main__":
    main()
