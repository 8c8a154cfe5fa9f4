"""Benchmark: time per element of every compiled kernel (energy + gradient + Hessian in one call).

Run from OUTSIDE the project root, so that `import ancf_sym` is the installed package with the compiled libraries:

    cd "$(mktemp -d)" && python "$OLDPWD"/bench/kernels.py --passes 3 --repeats 5   # all kernels, markdown on stdout
    cd "$(mktemp -d)" && python "$OLDPWD"/bench/kernels.py --only cable3d_axial_green,cable3d_bending

Columns (ns per element; "min / median" over --passes sweeps x --repeats batches, each batch timing enough calls
to last >= --min-time seconds; several passes spread the samples in time, against load from other processes):
- instr: n_instructions() of the kernel expanded to SX (MX kernels: `.expand()`), i.e. what the SX VM executes.
- single buf: one element, compiled, called through `Function.buffer()` (numpy memoryviews, no conversion).
- single DM: one element, compiled, the ordinary call casadi.Function.__call__(q, p) with numpy inputs (DM out).
- single DM checked: the same through ancf_sym.kernels.load(...)'s Kernel, which checks q and p first.
- map buf: compiled kernel mapped over --n elements (`f.map(n)`, serial), called through `buffer()`; per element.
- map thr2: the same with `f.map(n, 'thread', 2)`.
- SX VM map: the symbolic kernel (ancf_sym.codegen.definitions), expanded to SX, mapped serially, not compiled:
  CasADi's SX virtual machine; per element.
The bold rows "... axial_green + bending" add the two kernels' columns; the lines under the table time the two
mapped kernels called back to back (what an assembly of a cable with both effects does today). The speed target
is <= 1000 ns per element, mapped, for cable3d.
"""
from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

import casadi as ca
import numpy as np

if (Path.cwd() / "ancf_sym").is_dir():
    sys.exit("run this from outside the project root (any other directory), so that the installed, compiled ancf_sym is imported")

from ancf_sym import kernels, registry  # noqa: E402
from ancf_sym.util.casadi_buffers import bind  # noqa: E402

PARAM_DEFAULTS = {"L": 0.5, "xi": 0.5, "nu": 0.3, "E": 2e11, "b": 0.02, "h": 0.03, "J": 4.7e-8, "EA": 1.6e7, "EI": 1e2,
                  "nx": 0.0, "ny": 0.0, "nz": 1.0, "t0x": 1.0, "t0y": 0.0, "t0z": 0.0,
                  "ref1": 1.0, "ref2": 0.0, "ref3": 0.0, "gx": 0.0, "gy": -9.81, "gz": 0.0}

COMBOS = [("cable3d", ("axial_green", "bending")), ("cable2d", ("axial_green", "bending"))]


def element_inputs(element: str, params: tuple[str, ...], n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """n perturbed straight elements: q (n, ndof) and p (n, np), C order = CasADi's column-major (ndof, n)."""
    rng = np.random.default_rng(seed)
    el = registry.ELEMENTS[element]
    L = PARAM_DEFAULTS["L"]
    if element.startswith("cable"):
        d = el.dim
        e1 = np.eye(d)[0]
        q0 = np.concatenate([0 * e1, e1, L * e1, e1])
    else:
        I = np.eye(3)
        q0 = np.concatenate([np.zeros(3), I[0], I[1], I[2], L * I[0], I[0], I[1], I[2]])
    q = q0 + 0.05 * rng.standard_normal((n, el.ndof))
    p = np.tile([PARAM_DEFAULTS.get(name, 1.0) for name in params], (n, 1))
    return np.ascontiguousarray(q), np.ascontiguousarray(p)


class Timer:
    """Calls of fn, batched so one batch lasts >= min_time; batches are added by repeat() and kept."""

    def __init__(self, fn, min_time: float, per: int = 1):
        self.fn, self.per, self.samples = fn, per, []
        fn()
        n = 1
        while True:
            t0 = time.perf_counter()
            for _ in range(n):
                fn()
            dt = time.perf_counter() - t0
            if dt >= min_time:
                break
            n = max(n + 1, int(n * min(10.0, 1.2 * min_time / max(dt, 1e-9))))
        self.n = n
        self.samples.append(dt / n / per)

    def repeat(self, k: int) -> None:
        fn, n = self.fn, self.n
        for _ in range(k):
            t0 = time.perf_counter()
            for _ in range(n):
                fn()
            self.samples.append((time.perf_counter() - t0) / n / self.per)

    def stats(self) -> tuple[float, float]:
        return min(self.samples), statistics.median(self.samples)


class Buffered:
    """f evaluated through f.buffer() on fixed numpy arrays (inputs and outputs bound once)."""

    def __init__(self, f: ca.Function, args: list[np.ndarray]):
        self.f = f
        self.args = [np.ascontiguousarray(a, dtype=float) for a in args]
        self.res = [np.zeros(f.nnz_out(i)) for i in range(f.n_out())]
        self.buf, self.eval = bind(f, self.args, self.res)  # (checks each input's size)

    def __call__(self):
        self.eval()


def symbolic_sx(element: str, effect: str, gauss: int | None) -> ca.Function:
    from ancf_sym.codegen import definitions

    k = definitions.kernel(element, effect, gauss)
    return k.expand() if k.is_a("MXFunction") else k


def prepare_kernel(entry: dict, n: int, min_time: float, sx: bool, threads: int) -> tuple[dict, dict]:
    """(row, timers): static facts of one kernel and a Timer per column (each already holds one batch)."""
    element, effect, gauss = entry["element"], entry["effect"], entry["gauss"]
    f = kernels.load(element, effect, gauss)
    raw = ca.Function(f)  # the plain casadi.Function (no input checks of ancf_sym.kernels.Kernel)
    q, p = element_inputs(element, f.params, n)
    row = {"name": entry["name"], "element": element, "effect": effect, "gauss": gauss, "ndof": q.shape[1], "n": n}
    fsx = symbolic_sx(element, effect, gauss)
    row["instr"] = fsx.n_instructions()
    # correctness guards: compiled == SX VM on one element; mapped == single calls
    ref = [np.asarray(x) for x in fsx(q[0], p[0])]
    got = [np.asarray(x) for x in raw(q[0], p[0])]
    scale = max(1.0, max(float(np.max(np.abs(r))) for r in ref))
    row["max_abs_diff_vs_sx"] = max(float(np.max(np.abs(a - b))) for a, b in zip(ref, got)) / scale
    mapped = Buffered(raw.map(n), [q, p])
    mapped()
    e_one = np.array([float(raw(q[i], p[i])[0]) for i in (0, n - 1)])
    assert np.allclose(mapped.res[0][[0, n - 1]], e_one, rtol=1e-12, atol=1e-300), (entry["name"], e_one)

    q0, p0 = q[0], p[0]
    timers = {"single_buf": Timer(Buffered(raw, [q0, p0]), min_time),
              "single_dm": Timer(lambda: raw(q0, p0), min_time),
              "single_dm_checked": Timer(lambda: f(q0, p0), min_time),
              "map_buf": Timer(mapped, min_time, n)}
    if threads > 1:
        timers["map_thr"] = Timer(Buffered(raw.map(n, "thread", threads), [q, p]), min_time, n)
    if sx:
        timers["sx_map"] = Timer(Buffered(fsx.map(n), [q, p]), min_time, n)
    return row, timers


def combo_row(rows: dict, element: str, effects: tuple[str, ...]) -> dict:
    parts = [rows[registry.kernel_name(element, e)] for e in effects]
    out = {"name": f"{element} " + " + ".join(effects), "ndof": parts[0]["ndof"], "n": parts[0]["n"],
           "instr": sum(r["instr"] for r in parts), "combo": True}
    for key in ("single_buf", "single_dm", "single_dm_checked", "map_buf", "map_thr", "sx_map"):
        if all(key in r for r in parts):
            out[key] = (sum(r[key][0] for r in parts), sum(r[key][1] for r in parts))
    return out


def combo_timer(element: str, effects: tuple[str, ...], n: int, min_time: float) -> Timer:
    """The mapped kernels of `effects` called back to back in one timed function (per element)."""
    fs = []
    for e in effects:
        f = ca.Function(kernels.load(element, e))
        q, p = element_inputs(element, kernels.parameters(element, e), n)
        fs.append(Buffered(f.map(n), [q, p]))

    def both():
        for b in fs:
            b.eval()

    return Timer(both, min_time, n)


def fmt(t: tuple[float, float] | None, scale: float = 1e9) -> str:
    if t is None:
        return "-"
    a, b = (x * scale for x in t)
    digits = 0 if b >= 100 else 1
    return f"{a:.{digits}f} / {b:.{digits}f}"


def table(rows: list[dict], threads: int) -> str:
    head = ["kernel", "ndof", "instr (SX)", "single buf", "single DM", "single DM checked",
            f"map{rows[0]['n']} buf", f"map thread{threads}", "SX VM map"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        name = f"**{r['name']}**" if r.get("combo") else r["name"]
        lines.append("| " + " | ".join([
            name, str(r["ndof"]), str(r["instr"]), fmt(r.get("single_buf")), fmt(r.get("single_dm")),
            fmt(r.get("single_dm_checked")), fmt(r.get("map_buf")), fmt(r.get("map_thr")), fmt(r.get("sx_map"))]) + " |")
    return "\n".join(lines)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=1000, help="elements per mapped call")
    ap.add_argument("--repeats", type=int, default=7, help="timed batches per column and pass")
    ap.add_argument("--passes", type=int, default=1,
                    help="sweeps over all kernels; min/median over passes x repeats (spreads the samples in time)")
    ap.add_argument("--min-time", type=float, default=0.05, help="seconds per batch, at least")
    ap.add_argument("--threads", type=int, default=2, help="threads of the extra thread-map column (1: skip)")
    ap.add_argument("--no-sx", action="store_true", help="skip the SX virtual machine column")
    ap.add_argument("--only", default="", help="comma-separated kernel names (default: all in the catalogue)")
    ap.add_argument("--json", default="", help="also write the raw numbers (seconds) to this file")
    args = ap.parse_args(argv)

    load0 = open("/proc/loadavg").read().split()[:3]
    cat = kernels.catalogue()
    wanted = set(filter(None, args.only.split(",")))
    need = wanted | {registry.kernel_name(el, e) for el, effs in COMBOS for e in effs} if wanted else None
    rows, timers = {}, {}
    for entry in cat:
        if need is not None and entry["name"] not in need:
            continue
        t0 = time.perf_counter()
        rows[entry["name"]], timers[entry["name"]] = prepare_kernel(entry, args.n, args.min_time, not args.no_sx,
                                                                    args.threads)
        print(f"  {entry['name']}: prepared in {time.perf_counter() - t0:.1f} s", file=sys.stderr, flush=True)
    combos = {f"{el} " + " + ".join(effs): combo_timer(el, effs, args.n, args.min_time) for el, effs in COMBOS}
    for k in range(args.passes):
        t0 = time.perf_counter()
        for name, ts in timers.items():
            for t in ts.values():
                t.repeat(args.repeats - 1 if k == 0 else args.repeats)
        for t in combos.values():
            t.repeat(args.repeats - 1 if k == 0 else args.repeats)
        print(f"  pass {k + 1}/{args.passes}: {time.perf_counter() - t0:.0f} s", file=sys.stderr, flush=True)
    for name, ts in timers.items():
        rows[name].update({key: t.stats() for key, t in ts.items()})
    shown = [r for name, r in rows.items() if not wanted or name in wanted]
    for el, effs in COMBOS:
        c = combo_row(rows, el, effs)
        c["map_buf_together"] = combos[c["name"]].stats()
        shown.append(c)
    print(f"ns per element (single: per call), min / median over {args.passes} pass(es) x {args.repeats} batches of "
          f">= {args.min_time * 1e3:.0f} ms; load average before/after: {' '.join(load0)} / "
          f"{' '.join(open('/proc/loadavg').read().split()[:3])}\n")
    print(table(shown, args.threads))
    print()
    for c in shown:
        if c.get("combo"):
            ok = "meets" if c["map_buf_together"][0] * 1e9 <= 1000 else "MISSES"
            print(f"{c['name']}: the two mapped kernels back to back {fmt(c['map_buf_together'])} ns/element "
                  f"(min / median): {ok} the <= 1000 ns target")
    worst = max(r.get("max_abs_diff_vs_sx", 0.0) for r in rows.values())
    print(f"\ncompiled vs SX VM, largest relative difference over all kernels: {worst:.1e}")
    if args.json:
        Path(args.json).write_text(json.dumps(shown, indent=1))


if __name__ == "__main__":
    main()
