"""python -m ancf_sym.codegen [--check] [--out DIR]"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from ancf_sym.codegen import GENERATED, check, generate


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m ancf_sym.codegen", description=__doc__)
    ap.add_argument("--check", action="store_true", help="exit non-zero if generated/ is stale")
    ap.add_argument("--out", type=Path, default=GENERATED, help="output folder (default: generated/)")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    if args.check:
        stale = check(args.out)
        if stale:
            print(f"generated/ is stale: {len(stale)} file(s) differ from the symbolic definitions:", file=sys.stderr)
            for name in stale:
                print(f"  {name}", file=sys.stderr)
            print("run: python -m ancf_sym.codegen", file=sys.stderr)
            return 1
        print(f"generated/ is up to date ({time.perf_counter() - t0:.1f} s)")
        return 0
    m = generate(args.out, verbose=True)
    libs = {k["library"] for k in m["kernels"]}
    print(f"wrote {len(m['kernels'])} kernels in {len(libs)} C files to {args.out} in {time.perf_counter() - t0:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
