"""Investigation: why cable3d axial_green + bending costs what it does, and which kernel form is faster.

    cd "$(mktemp -d)" && python "$OLDPWD"/bench/kernel_forms.py parts            # operation counts per part
    cd "$(mktemp -d)" && python "$OLDPWD"/bench/kernel_forms.py forms --dim 3    # form x gcc flags, axial_green+bending
    cd "$(mktemp -d)" && python "$OLDPWD"/bench/kernel_forms.py perkernel        # MX+calls vs all-SX, per kernel, -O2
    cd "$(mktemp -d)" && python "$OLDPWD"/bench/kernel_forms.py tail             # where the MX form's overhead goes

Everything is built here from the installed package's symbolic code (ancf_sym.codegen.definitions, forms,
elements.cable), generated to C in a temporary folder, compiled with gcc, loaded with casadi.external and timed
mapped over --n elements through Function.buffer(). Variants are timed interleaved (round-robin, --rounds rounds of
~30 ms each), so load from other processes hits all of them alike; the min is the least-disturbed figure.

Forms:
- MX+calls: the shipped form, an MX kernel calling one SX point function (q, p, xi, w) per Gauss point, summing
  e, g, tril(H) in MX and mirroring tril(H) to the dense Hessian at the end.
- all-SX: the same kernel `.expand()`-ed to one straight-line SX function before code generation.
- fused: axial_green and bending as ONE density of u = [r_x, r_xx], p = [L, EA, EI]: one B^T f_uu B per point
  instead of two, one accumulation and one mirror instead of two.
"""
from __future__ import annotations

import argparse
import importlib.util
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import casadi as ca
import numpy as np

if (Path.cwd() / "ancf_sym").is_dir():
    sys.exit("run this from outside the project root (any other directory), so that the installed, compiled ancf_sym is imported")

from ancf_sym import kernels  # noqa: E402
from ancf_sym.codegen import definitions, forms  # noqa: E402
from ancf_sym.elements import cable  # noqa: E402
from ancf_sym.elements.quadrature import gauss01  # noqa: E402

_spec = importlib.util.spec_from_file_location("bench_kernels", Path(__file__).with_name("kernels.py"))
bk = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(bk)

FLAGS = {"O2": ["-O2"], "O3": ["-O3"], "O2n": ["-O2", "-march=native"], "O3n": ["-O3", "-march=native"]}
SKIP = {ca.OP_CONST, ca.OP_INPUT, ca.OP_OUTPUT, ca.OP_PARAMETER}
CG = {"with_header": False, "casadi_real": "double", "casadi_int": "long long int"}


def nops(f: ca.Function) -> int:
    """Arithmetic instructions of f expanded to SX (no constants, inputs, outputs)."""
    f = f.expand() if f.is_a("MXFunction") else f
    return sum(1 for k in range(f.n_instructions()) if f.instruction_id(k) not in SKIP)


def ndiv(f: ca.Function) -> int:
    f = f.expand() if f.is_a("MXFunction") else f
    return sum(1 for k in range(f.n_instructions()) if f.instruction_id(k) == ca.OP_DIV)


# -------------------------------------------------------------------------------------------------- fused kernel
def fused_point(q, p, xi, w, dim):
    """(e, g, tril H) of axial_green + bending at one station, one density of u = [r_x, r_xx]."""
    L = p[0]
    u = ca.vertcat(cable.slope(q, L, xi, dim), cable.curvature_vector(q, L, xi, dim))
    v = ca.SX.sym("v", 2 * dim)
    f = w * L * (cable.green_density(v[:dim], p[1]) + cable.bending_density(v[:dim], v[dim:], p[2]))
    fu, fuu = ca.gradient(f, v), ca.hessian(f, v)[0]
    f, fu, fuu = ca.substitute([f, fu, fuu], [v], [u])
    B = ca.jacobian(u, q)
    return f, ca.mtimes(B.T, fu), forms.lower_product(B, fuu)


def fused_kernel(name: str, dim: int, form: str, gauss: int = 5) -> ca.Function:
    nq = 4 * dim
    xs, ws = gauss01(gauss)
    if form == "SX":
        q, p = ca.SX.sym("q", nq), ca.SX.sym("p", 3)
        e, g, H = 0, 0, 0
        for x, w in zip(xs, ws):
            de, dg, dH = fused_point(q, p, float(x), float(w), dim)
            e, g, H = e + de, g + dg, H + dH
    else:
        qs, ps, xi, ww = ca.SX.sym("q", nq), ca.SX.sym("p", 3), ca.SX.sym("xi"), ca.SX.sym("w")
        pt = ca.Function(name + "_point", [qs, ps, xi, ww], list(fused_point(qs, ps, xi, ww, dim)))
        q, p = ca.MX.sym("q", nq), ca.MX.sym("p", 3)
        e, g, H = 0, 0, 0
        for x, w in zip(xs, ws):
            de, dg, dH = pt(q, p, float(x), float(w))
            e, g, H = e + de, g + dg, H + dH
    return ca.Function(name, [q, p], [e, g, ca.densify(ca.tril2symm(H))], ["q", "p"], ["energy", "gradient", "hessian"])


# -------------------------------------------------------------------------------------------------- build + time
class Builder:
    def __init__(self):
        self.dir = Path(tempfile.mkdtemp(prefix="ancf_forms_"))

    def compile(self, f: ca.Function, flags: list[str]) -> tuple[ca.Function, float, int]:
        c = self.dir / (f.name() + ".c")
        if not c.exists():
            cwd = os.getcwd()
            os.chdir(self.dir)
            try:
                cg = ca.CodeGenerator(c.name, CG)
                cg.add(f)
                cg.generate()
            finally:
                os.chdir(cwd)
        so = self.dir / f"{f.name()}_{'_'.join(x.strip('-').replace('=', '') for x in flags)}.so"
        t0 = time.perf_counter()
        subprocess.run(["gcc", "-fPIC", "-shared", *flags, str(c), "-o", str(so), "-lm"], check=True)
        ct = time.perf_counter() - t0
        return ca.external(f.name(), str(so)), ct, sum(1 for _ in open(c))


def interleaved(entries: dict, n: int, rounds: int) -> None:
    """entries[key]['bufs']: Buffered mapped calls timed together; fills entries[key]['t'] in ns per element."""
    for e in entries.values():
        for b in e["bufs"]:
            b.eval()
        t0 = time.perf_counter()
        for b in e["bufs"]:
            b.eval()
        e["reps"] = max(1, int(0.03 / max(time.perf_counter() - t0, 1e-6)))
        e["t"] = []
    for _ in range(rounds):
        for e in entries.values():
            t0 = time.perf_counter()
            for _ in range(e["reps"]):
                for b in e["bufs"]:
                    b.eval()
            e["t"].append((time.perf_counter() - t0) / e["reps"] / n * 1e9)


def cmd_forms(args) -> None:
    dim, el, both = args.dim, f"cable{args.dim}d", ("axial_green", "bending")
    n = args.n
    q, _ = bk.element_inputs(el, ("L", "EA"), n)
    P = {"L": 0.5, "EA": 1.6e7, "EI": 1e2}
    p2 = {e: np.tile([P["L"], P["EA" if e == "axial_green" else "EI"]], (n, 1)) for e in both}
    p3 = np.tile([P["L"], P["EA"], P["EI"]], (n, 1))
    ref = [sum(np.asarray(kernels.load(el, e)(q[0], p2[e][0])[i]) for e in both) for i in range(3)]
    variants = {
        "MX+calls (shipped), 2 kernels": [definitions.kernel(el, e, 5) for e in both],
        "all-SX, 2 kernels": [definitions.kernel(el, e, 5).expand(f"{el}_{e}_sx") for e in both],
        "fused, MX+calls": [fused_kernel(f"{el}_fused_mx", dim, "MX")],
        "fused, all-SX": [fused_kernel(f"{el}_fused_sx", dim, "SX")],
    }
    bld, entries = Builder(), {}
    for vname, fs in variants.items():
        for fl in args.flags.split(","):
            libs, ct = [], 0.0
            for f in fs:
                lib, t, _ = bld.compile(f, FLAGS[fl])
                libs.append(lib)
                ct += t
            if len(libs) == 2:
                got = [sum(np.asarray(lib(q[0], p2[e][0])[i]) for lib, e in zip(libs, both)) for i in range(3)]
                bufs = [bk.Buffered(lib.map(n), [q, p2[e]]) for lib, e in zip(libs, both)]
            else:
                got = [np.asarray(x) for x in libs[0](q[0], p3[0])]
                bufs = [bk.Buffered(libs[0].map(n), [q, p3])]
            err = max(float(np.max(np.abs(a - b)) / max(1.0, np.max(np.abs(b)))) for a, b in zip(got, ref))
            entries[(vname, fl)] = {"bufs": bufs, "ops": sum(nops(f) for f in fs), "divs": sum(ndiv(f) for f in fs),
                                    "ct": ct, "err": err}
            print(f"  built {vname} {fl}", file=sys.stderr, flush=True)
    interleaved(entries, n, args.rounds)
    base = min(entries[next(iter(entries))]["t"])
    print(f"\n{el} axial_green + bending, energy+gradient+Hessian, mapped over {n} elements, buffer calls; "
          f"load average {open('/proc/loadavg').read().split()[0:3]}\n")
    print("| form | gcc flags | ops | of which DIV | compile s | ns/element min | median | speedup (min) | rel. diff vs installed |")
    print("|---|---|---|---|---|---|---|---|---|")
    for (vname, fl), e in entries.items():
        print(f"| {vname} | {' '.join(FLAGS[fl])} | {e['ops']} | {e['divs']} | {e['ct']:.2f} | {min(e['t']):.0f} | "
              f"{statistics.median(e['t']):.0f} | {base / min(e['t']):.2f}x | {e['err']:.0e} |")


def cmd_perkernel(args) -> None:
    bld, entries, n = Builder(), {}, args.n
    flags = FLAGS[args.flags.split(",")[0]]
    for nm in args.kernels.split(","):
        el, eff = nm.split("/")
        k = definitions.kernel(el, eff, None)
        q, p = bk.element_inputs(el, kernels.parameters(el, eff), n)
        for form, f in (("MX+calls", k), ("all-SX", k.expand(k.name() + "_sx"))):
            lib, ct, lines = bld.compile(f, flags)
            entries[(nm, form)] = {"bufs": [bk.Buffered(lib.map(n), [q, p])], "ops": nops(f), "ct": ct, "lines": lines}
            print(f"  built {nm} {form}", file=sys.stderr, flush=True)
    interleaved(entries, n, args.rounds)
    print(f"\nper kernel, mapped over {n}, gcc {' '.join(flags)}; load average {open('/proc/loadavg').read().split()[0:3]}\n")
    print("| kernel | form | C lines | compile s | ops | ns/element min | median |\n|---|---|---|---|---|---|---|")
    for (nm, form), e in entries.items():
        print(f"| {nm} | {form} | {e['lines']} | {e['ct']:.1f} | {e['ops']} | {min(e['t']):.0f} | {statistics.median(e['t']):.0f} |")


def cmd_tail(args) -> None:
    """Where the MX form's overhead goes, on cable3d axial_green (-O2): the final mirror vs the per-point calls."""
    el, eff, n = "cable3d", "axial_green", args.n
    pt = definitions.point_function(el, eff)
    xs, ws = gauss01(5)
    qs, ps, xi, w = ca.SX.sym("q", 12), ca.SX.sym("p", 2), ca.SX.sym("xi"), ca.SX.sym("w")
    e1, g1, H1 = pt(qs, ps, xi, w)
    ptd = ca.Function("ptd", [qs, ps, xi, w], [e1, g1, ca.densify(ca.tril2symm(H1))])

    def mx(name, point, tail):
        q, p = ca.MX.sym("q", 12), ca.MX.sym("p", 2)
        e = g = H = 0
        for x, ww in zip(xs, ws):
            de, dg, dH = point(q, p, float(x), float(ww))
            e, g, H = e + de, g + dg, H + dH
        return ca.Function(name, [q, p], [e, g, tail(H)])

    variants = {
        "MX+calls as shipped: sum tril(H) in MX, mirror to dense at the end": mx("t_ship", pt, lambda H: ca.densify(ca.tril2symm(H))),
        "MX+calls, output tril(H) (no mirror)": mx("t_tril", pt, lambda H: H),
        "MX+calls, point function returns dense symmetric H, dense sums": mx("t_dense", ptd, lambda H: H),
        "all-SX (kernel.expand())": definitions.kernel(el, eff, 5).expand("t_sx"),
    }
    q, p = bk.element_inputs(el, ("L", "EA"), n)
    bld, entries = Builder(), {}
    for k, f in variants.items():
        lib, _, _ = bld.compile(f, ["-O2"])
        entries[k] = {"bufs": [bk.Buffered(lib.map(n), [q, p])]}
    interleaved(entries, n, args.rounds)
    print(f"\n{el}_{eff}, mapped over {n}, gcc -O2; load average {open('/proc/loadavg').read().split()[0:3]}\n")
    print("| variant | ns/element min | median |\n|---|---|---|")
    for k, e in entries.items():
        print(f"| {k} | {min(e['t']):.0f} | {statistics.median(e['t']):.0f} |")


def cmd_parts(args) -> None:
    print("| kernel | part | ops |\n|---|---|---|")
    for dim in (3, 2):
        el, nq = f"cable{dim}d", 4 * dim
        q, p = ca.SX.sym("q", nq), ca.SX.sym("p", 2)
        L, xi, w = p[0], 0.3, 0.2
        for eff in ("axial_green", "bending"):
            k = definitions.kernel(el, eff, 5)
            rx = cable.slope(q, L, xi, dim)
            if eff == "axial_green":
                u, dens = rx, (lambda v: cable.green_density(v, p[1]))
            else:
                u = ca.vertcat(rx, cable.curvature_vector(q, L, xi, dim))
                dens = (lambda v: cable.bending_density(v[:dim], v[dim:], p[1]))
            nu = u.shape[0]
            v = ca.SX.sym("v", nu)
            f = w * L * dens(v)
            B = ca.jacobian(u, q)
            Al, a = ca.SX.sym("A", ca.Sparsity.lower(nu)), ca.SX.sym("a", nu)
            rows = [
                ("whole kernel, expanded to SX (5 points)", nops(k)),
                ("  of which DIV", ndiv(k)),
                ("SX point function as compiled (xi, w symbolic), per call", nops(definitions.point_function(el, eff))),
                (f"per point: density f, f_u, f_uu (u: {nu})", nops(ca.Function("d", [v, p], [f, ca.gradient(f, v), ca.hessian(f, v)[0]]))),
                ("per point: u = B q", nops(ca.Function("u", [q, p], [u]))),
                ("per point: B^T f_u", nops(ca.Function("g", [p, a], [ca.mtimes(B.T, a)]))),
                ("per point: tril(B^T f_uu B)", nops(ca.Function("h", [p, Al], [forms.lower_product(B, ca.tril2symm(Al))]))),
                ("accumulation over 5 points (adds)", 4 * (1 + nq + nq * (nq + 1) // 2)),
            ]
            for part, c in rows:
                print(f"| {el}_{eff} | {part} | {c} |")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("what", choices=["parts", "forms", "perkernel", "tail"])
    ap.add_argument("--dim", type=int, default=3)
    ap.add_argument("--n", type=int, default=1000)
    ap.add_argument("--rounds", type=int, default=15)
    ap.add_argument("--flags", default="O2,O3,O2n,O3n", help=f"comma-separated keys of {FLAGS}")
    ap.add_argument("--kernels", default="cable3d/axial_green,cable3d/bending,cable3d/axial_biot,cable2d/axial_green,"
                                          "cable2d/bending,beam3d/line_strain,beam3d/line_bending,beam3d/line_torsion")
    args = ap.parse_args(argv)
    {"parts": cmd_parts, "forms": cmd_forms, "perkernel": cmd_perkernel, "tail": cmd_tail}[args.what](args)


if __name__ == "__main__":
    main()
