"""Cost of `casadi_buffers.bind` against the hand-written binding it replaced, on a compiled kernel.

Two figures, each the min (and median) over --repeats repeats:
- per call: the hot path, `evaluate()` of a bound buffer, --calls calls; bound by hand (f.buffer(), set_arg/set_res
  with memoryviews) vs by `bind`. `bind` returns CasADi's own callable, so the two must agree to timing noise.
- per binding: one binding of all inputs and outputs (done once per set-up; `bind` also checks the arrays).

Run from outside the project root (so that `import ancf_sym` is the installed package):
    python bench/buffer_binding.py [--n 1] [--calls 100000] [--repeats 7]
"""
from __future__ import annotations

import argparse
import statistics
import timeit

import numpy as np

from ancf_sym import kernels
from ancf_sym.util.casadi_buffers import bind


def by_hand(f, args, res):
    buf, ev = f.buffer()
    for i, a in enumerate(args):
        buf.set_arg(i, memoryview(a))
    for i, r in enumerate(res):
        buf.set_res(i, memoryview(r))
    return buf, ev


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=1, help="elements the cable2d elastic_green kernel is mapped over")
    ap.add_argument("--calls", type=int, default=100_000, help="evaluations per timed repeat")
    ap.add_argument("--repeats", type=int, default=7)
    a = ap.parse_args()
    f = kernels.load("cable2d", "elastic_green").map(a.n)
    X = np.linspace(0.0, 1.0, 8)[None, :] * np.ones((a.n, 1))
    P = np.ones((a.n, f.size_in(1)[0]))
    res = (np.zeros(a.n), np.zeros((a.n, 8)), np.zeros((a.n, 8, 8)))
    pairs = {"by hand": by_hand(f, (X, P), res), "bind": bind(f, (X, P), res)}
    binders = {"by hand": by_hand, "bind": bind}
    nb = max(a.calls // 100, 1)
    call: dict[str, list[float]] = {k: [] for k in pairs}
    binding: dict[str, list[float]] = {k: [] for k in pairs}
    for _ in range(a.repeats):  # interleaved (round-robin), so that a load change on the machine hits both alike
        for name, (buf, ev) in pairs.items():
            call[name].append(timeit.timeit(ev, number=a.calls) / a.calls * 1e6)
        for name, fn in binders.items():
            binding[name].append(timeit.timeit(lambda: fn(f, (X, P), res), number=nb) / nb * 1e6)
    print(f"cable2d elastic_green mapped over {a.n} element(s); us, min / median over {a.repeats} repeats")
    for what, t in (("per call", call), ("per binding", binding)):
        for name, v in t.items():
            print(f"  {what:12s} {name:8s} {min(v):9.3f} / {statistics.median(v):9.3f}")

if __name__ == "__main__":
    main()
