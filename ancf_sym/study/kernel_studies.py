"""Kernel-level study: what one element evaluation (energy + gradient + Hessian) costs in each form of
the same kernel, and that every form computes the same numbers (round-off only).

Forms (axis `form`):
- compiled: C code run through casadi.external. Per-effect kernels always come from the installed libraries; a
  fused kernel comes from the installed library when the package ships one (internal effect `elastic_green` of the
  cables, `kernels.catalogue()`), otherwise it is generated here and compiled with gcc (the install's flags) in a
  temporary folder. The record's `source` column says which.
- sx_vm: the same kernel built at run time from the symbolic definitions (ancf_sym.codegen.definitions), expanded
  to one SX function and evaluated by CasADi's SX virtual machine (no C compiler involved).
Split (axis `split`):
- per_effect: one kernel per effect, called back to back (cables: axial_green + bending; beam3d: the elastic-line
  forces line_strain + line_bending + line_torsion), outputs summed.
- fused: one kernel for all of them (cables: one density of u = (r_x, r_xx) with one B^T f_uu B per Gauss point;
  beam3d: one point function holding the three elastic-line terms: one call, one accumulation, one mirror).
"""
from __future__ import annotations

import functools
import os
import statistics
import subprocess
import tempfile
import time

import numpy as np

from ancf_sym.util.casadi_buffers import bind
from ancf_sym.registry import GAUSS_ORDERS
from ancf_sym.study.base import Axis, Study

ELEMENTS = ("cable2d", "cable3d", "beam3d")
FORMS = ("compiled", "sx_vm")
SPLITS = ("per_effect", "fused")
PARTS = {"cable2d": ("axial_green", "bending"), "cable3d": ("axial_green", "bending"),
         "beam3d": ("line_strain", "line_bending", "line_torsion")}
TARGET = 1e-10
# Differences below half an ulp of the largest entry are not resolvable in double precision: the error is floored
# there (identical results show as 1.1e-16, the raw figure stays in the `raw_diff` column).
FLOOR = float(np.finfo(float).eps) / 2
# Round-off of any form (the reference included) against exact arithmetic, relative to the largest entry: about
# (operations in a dependency chain, <= 1e4 in these kernels) x eps. Errors below 3x this bound are not fitted
# for a "convergence rate" in the Gauss order: there is nothing to converge, the forms are the same function.
ROUND_OFF_BOUND = 1e-12

# A steel bar, 20 mm x 30 mm, elements of 0.5 m (the cables use its EA and the EI about its weak axis).
_L, _E, _NU, _B, _H = 0.5, 2e11, 0.3, 0.02, 0.03
_G = _E / (2 * (1 + _NU))
PARAMS = {"L": _L, "E": _E, "nu": _NU, "b": _B, "h": _H, "EA": _E * _B * _H, "EI": _E * _H * _B**3 / 12,
          "EIy": _E * _B * _H**3 / 12, "EIz": _E * _H * _B**3 / 12, "GIp": _G * _B * _H * (_B**2 + _H**2) / 12,
          "J": 4.7e-8}  # J: St. Venant's torsion constant of the 20 x 30 mm rectangle
BEAM_FUSED_PARAMS = ("L", "b", "h", "E", "nu", "EIy", "EIz", "GIp")

# Batches short enough that some run without preemption on a shared machine, many of them (the min is kept).
_VARIANT = {"full": {"n": 1000, "min_time": 0.005, "repeats": 50}, "quick": {"n": 200, "min_time": 0.002, "repeats": 10}}
_CG = {"with_header": False, "casadi_real": "double", "casadi_int": "long long int"}


# -- states ---------------------------------------------------------------------------------------------------------
def element_states(element: str, n: int, seed: int = 6) -> np.ndarray:
    """n random deformed elements (n, ndof), C order = CasADi's column-major (ndof, n) of a mapped call: straight
    elements of length L along x with positions perturbed by N(0, (0.1 L)^2) and gradients by N(0, 0.1^2)
    (about 10 % stretch and 0.1 rad of bending per element, never near a degenerate |r_x|)."""
    from ancf_sym import registry
    el = registry.ELEMENTS[element]
    rng = np.random.default_rng(seed)
    if element.startswith("cable"):
        e1 = np.eye(el.dim)[0]
        q0 = np.concatenate([0 * e1, e1, _L * e1, e1])
        scale = np.concatenate([np.full(el.dim, _L), np.ones(el.dim)] * 2)
    else:
        eye = np.eye(3)
        q0 = np.concatenate([np.zeros(3), eye[0], eye[1], eye[2], _L * eye[0], eye[0], eye[1], eye[2]])
        scale = np.concatenate([np.full(3, _L), np.ones(9)] * 2)
    return np.ascontiguousarray(q0 + 0.1 * scale * rng.standard_normal((n, el.ndof)))


def param_matrix(names: tuple[str, ...], n: int) -> np.ndarray:
    return np.ascontiguousarray(np.tile([PARAMS[k] for k in names], (n, 1)))


# -- the forms --------------------------------------------------------------------------------------------------------
def installed_fused(element: str, gauss: int):
    """The compiled fused kernel of the installed package (cables: internal effect axial_green + bending), or None
    when this installation has none."""
    from ancf_sym import kernels, registry
    find = getattr(registry, "fused_effect", None)
    effect = find(element, PARTS[element]) if find else None
    if effect is None:
        return None
    try:
        return kernels.load(element, effect, gauss), effect
    except (kernels.KernelError, FileNotFoundError):
        return None


def _fused_station(element: str):
    """Quadrature station of the fused kernel: (u, density, scale) triples, p = the fused parameter vector."""
    import casadi as ca
    from ancf_sym import registry
    from ancf_sym.codegen import definitions
    from ancf_sym.elements import cable

    if element.startswith("cable"):
        dim = registry.ELEMENTS[element].dim

        def station(q, p, xi, w):  # same density as the installed elastic_green (codegen.definitions.FUSED)
            L = p[0]
            u = ca.vertcat(cable.slope(q, L, xi, dim), cable.curvature_vector(q, L, xi, dim))
            yield u, lambda v, p: cable.green_density(v[:dim], p[1]) + cable.bending_density(v[:dim], v[dim:], p[2]), \
                w * L
        return station

    def station(q, p, xi, w):
        for eff in PARTS[element]:
            names = registry.EFFECTS[(element, eff)].params
            psub = ca.vertcat(*[p[BEAM_FUSED_PARAMS.index(k)] for k in names])
            for u, dens, scale in definitions.beam_station(eff)(q, psub, xi, w):
                yield u, (lambda v, _p, dens=dens, psub=psub: dens(v, psub)), scale
    return station


def fused_params(element: str) -> tuple[str, ...]:
    return ("L", "EA", "EI") if element.startswith("cable") else BEAM_FUSED_PARAMS


@functools.lru_cache(maxsize=None)
def fused_symbolic(element: str, gauss: int):
    """The fused kernel (q, p) -> (e, g, H) as a CasADi Function: the installed package's own definition when it has
    one (so the SX VM runs exactly what was compiled), else built here; cables as one straight-line SX function
    (like the shipped cable kernels), beam3d as one point function called per Gauss point (like the shipped beam
    kernels)."""
    from ancf_sym import registry
    from ancf_sym.codegen import definitions, forms

    find = getattr(registry, "fused_effect", None)
    effect = find(element, PARTS[element]) if find else None
    if effect is not None:
        return definitions.kernel(element, effect, gauss)
    nq = registry.ELEMENTS[element].ndof
    name = f"{element}_study_fused_g{gauss}"
    point = forms.point_function(name + "_point", nq, len(fused_params(element)), _fused_station(element))
    k = forms.quadrature_kernel(name, point, gauss)
    return k.expand(name, {}) if element.startswith("cable") else k


@functools.lru_cache(maxsize=None)
def per_effect_symbolic(element: str, effect: str, gauss: int):
    from ancf_sym.codegen import definitions
    return definitions.kernel(element, effect, gauss)


def as_sx(f):
    return f.expand() if f.is_a("MXFunction") else f


def sx_ops(f) -> int:
    """Arithmetic instructions of f expanded to SX (constants, inputs and outputs not counted)."""
    import casadi as ca
    f = as_sx(f)
    skip = {ca.OP_CONST, ca.OP_INPUT, ca.OP_OUTPUT, ca.OP_PARAMETER}
    return sum(1 for k in range(f.n_instructions()) if f.instruction_id(k) not in skip)


@functools.lru_cache(maxsize=None)
def compile_at_run_time(element: str, gauss: int, cflags: tuple[str, ...] = ("-O2",)):
    """The fused kernel generated to C and compiled with gcc in a temporary folder; (Function, compile seconds)."""
    import casadi as ca
    f = fused_symbolic(element, gauss)
    with tempfile.TemporaryDirectory(prefix="ancf_kernel_study_") as tmp:
        cwd = os.getcwd()
        os.chdir(tmp)
        try:
            cg = ca.CodeGenerator(f.name() + ".c", _CG)
            cg.add(f)
            cg.generate()
        finally:
            os.chdir(cwd)
        so = os.path.join(tmp, f.name() + ".so")
        t0 = time.perf_counter()
        subprocess.run(["gcc", "-fPIC", "-shared", *cflags, os.path.join(tmp, f.name() + ".c"), "-o", so, "-lm"],
                       check=True, capture_output=True)
        ct = time.perf_counter() - t0
        return ca.external(f.name(), so), ct  # dlopen-ed: the file may go with the folder


def build_form(element: str, form: str, split: str, gauss: int) -> dict:
    """The kernels of one setting: {'fns': [(Function, param names)], 'source': ..., 'ops': ..., 'build_s': ...}."""
    import casadi as ca
    from ancf_sym import kernels

    t0 = time.perf_counter()
    if split == "per_effect":
        effects = PARTS[element]
        pnames = [kernels.parameters(element, e) for e in effects]
        syms = [per_effect_symbolic(element, e, gauss) for e in effects]
        if form == "compiled":
            fns = [ca.Function(kernels.load(element, e, gauss)) for e in effects]  # plain Function: no input checks
            source = "installed libraries"
        else:
            fns = [as_sx(s) for s in syms]
            source = "CasADi SX VM"
    else:
        pnames = [fused_params(element)]
        syms = [fused_symbolic(element, gauss)]
        if form == "compiled":
            got = installed_fused(element, gauss)
            if got is not None:
                fns, source = [ca.Function(got[0])], f"installed library ({got[1]})"
                pnames = [kernels.parameters(element, got[1])]
            else:
                cflags = tuple(next(k["cflags"] for k in kernels.catalogue()
                                    if k["element"] == element and k["effect"] == PARTS[element][0]))
                f, _ = compile_at_run_time(element, gauss, cflags)
                fns, source = [f], f"generated and compiled here (gcc {' '.join(cflags)})"
        else:
            fns, source = [as_sx(syms[0])], "CasADi SX VM"
    return {"fns": list(zip(fns, pnames)), "source": source, "ops": sum(sx_ops(s) for s in syms),
            "build_s": time.perf_counter() - t0}


_clock = time.process_time  # CPU time of this process (the kernels run single-threaded: map is serial)


# -- evaluation and timing --------------------------------------------------------------------------------------------
class Buffered:
    """f evaluated through f.buffer() on fixed numpy arrays (inputs and outputs bound once, no conversions)."""

    def __init__(self, f, args: list[np.ndarray]):
        self.args = [np.ascontiguousarray(a, dtype=float) for a in args]
        for i in range(f.n_out()):
            if f.nnz_out(i) != f.numel_out(i):
                raise ValueError(f"{f.name()}: output {i} is not dense")
        self.res = [np.zeros(f.nnz_out(i)) for i in range(f.n_out())]
        self.buf, self.eval = bind(f, self.args, self.res)  # (checks each input's size)


def mapped(fns: list, q: np.ndarray) -> list[Buffered]:
    n = q.shape[0]
    return [Buffered(f.map(n), [q, param_matrix(names, n)]) for f, names in fns]


def summed_outputs(bufs: list[Buffered]) -> list[np.ndarray]:
    """Energy, gradient and Hessian of every element (flat, column-major), summed over the kernels."""
    for b in bufs:
        b.eval()
    return [sum(b.res[i] for b in bufs) for i in range(3)]


def relative_differences(got: list[np.ndarray], ref: list[np.ndarray]) -> dict[str, float]:
    """max |got - ref| / max |ref| per output over all elements (entries near zero make entrywise ratios
    meaningless; the largest entry is the scale round-off lives on)."""
    return {k: float(np.max(np.abs(a - b)) / np.max(np.abs(b)))
            for k, a, b in zip(("energy", "gradient", "hessian"), got, ref)}


def time_per_element(groups: list[list[Buffered]], n: int, min_time: float, repeats: int) -> list[tuple[float, float]]:
    """(min, median) seconds per element of each group of mapped kernels (called back to back), over `repeats`
    batches each lasting >= min_time. The groups' batches alternate (round-robin), so load from other processes
    drifting in time hits them alike and their ratio is steadier than their absolute times. The clock is this
    process' CPU time: time the scheduler gives to other processes does not count (on a shared machine it would
    dominate the figures); what remains of their disturbance (caches, memory bandwidth) the min over batches cuts."""
    calls, counts = [], []
    for bufs in groups:
        evals = [b.eval for b in bufs]

        def once(evals=evals):
            for e in evals:
                e()

        once()
        k = 1
        while True:
            t0 = _clock()
            for _ in range(k):
                once()
            dt = _clock() - t0
            if dt >= min_time:
                break
            k = max(k + 1, int(k * min(10.0, 1.2 * min_time / max(dt, 1e-9))))
        calls.append(once)
        counts.append(k)
    samples = [[] for _ in groups]
    for _ in range(repeats):
        for once, k, smp in zip(calls, counts, samples):
            t0 = _clock()
            for _ in range(k):
                once()
            smp.append((_clock() - t0) / k / n)
    return [(min(smp), statistics.median(smp)) for smp in samples]


def kernels_run(setting: dict, variant: str) -> dict:
    from ancf_sym import kernels
    cfg = _VARIANT[variant]
    el, gauss, n = setting["element"], int(setting["gauss"]), cfg["n"]
    q = element_states(el, n)
    ref_fns = [(kernels.load(el, e, gauss), kernels.parameters(el, e)) for e in PARTS[el]]
    import casadi as ca
    ref_bufs = mapped([(ca.Function(f), p) for f, p in ref_fns], q)
    ref = summed_outputs(ref_bufs)
    form = build_form(el, setting["form"], setting["split"], gauss)
    bufs = mapped(form["fns"], q)
    diffs = relative_differences(summed_outputs(bufs), ref)
    (t_min, t_med), (r_min, _) = time_per_element([bufs, ref_bufs], n, cfg["min_time"], cfg["repeats"])
    return {"status": "ok", "success": True, "wall_s": t_min, "ns_min": t_min * 1e9, "ns_median": t_med * 1e9,
            "ref_ns_min": r_min * 1e9, "speedup_vs_ref": r_min / t_min,
            "kernels": len(bufs), "sx_ops": form["ops"], "source": form["source"], "build_s": form["build_s"],
            "diff_energy": diffs["energy"], "diff_gradient": diffs["gradient"], "diff_hessian": diffs["hessian"],
            "raw_diff": max(diffs.values()), "n_elements": n}


def kernels_error(rec: dict, ref: dict) -> float:
    """The error (floored at half an ulp); also sets the record's load-normalised time (see _TIMING): wall_s =
    ns_min x baseline / ref_ns_min, where the baseline is the compiled per-effect kernels' time measured once by the
    reference and ref_ns_min the same kernels timed interleaved with this run. Forms of one (element, Gauss order)
    then compare as their interleaved ratios do, whatever the load when each ran; ns_min keeps the raw time."""
    base = (ref.get("baseline_ns") or {}).get(f"{rec['element']},{int(rec['gauss'])}")
    if base and rec.get("ref_ns_min"):
        rec["ns_norm"] = rec["ns_min"] * base / rec["ref_ns_min"]
        rec["wall_s"] = rec["ns_norm"] * 1e-9
    return max(float(rec["raw_diff"]), FLOOR)


def kernels_reference(variant: str) -> dict:
    """What the errors compare against, and the baseline time of the compiled per-effect kernels of every element
    and Gauss order (min over the variant's batches)."""
    import casadi as ca
    from ancf_sym import kernels, registry
    cfg = _VARIANT[variant]
    n = cfg["n"]
    baseline = {}
    for el in ELEMENTS:
        q = element_states(el, n)
        for g in registry.EFFECTS[(el, PARTS[el][0])].gauss:
            bufs = mapped([(ca.Function(kernels.load(el, e, g)), kernels.parameters(el, e)) for e in PARTS[el]], q)
            baseline[f"{el},{g}"] = time_per_element([bufs], n, cfg["min_time"], cfg["repeats"])[0][0] * 1e9
    return {"how": f"the installed compiled per-effect kernels ({', '.join(f'{e}: ' + ' + '.join(p) for e, p in PARTS.items())}) "
                   f"evaluated on the same {n} random deformed elements as every setting (seed 6)",
            "n_elements": n, "baseline_ns": baseline, "error_bound": ROUND_OFF_BOUND, "success": True}


# -- conclusions ------------------------------------------------------------------------------------------------------
def _ratio_text(rs: list[float]) -> str:
    if not rs:
        return "-"
    if len(rs) == 1:
        return f"{rs[0]:.2f}x"
    return f"{min(rs):.2f}-{max(rs):.2f}x (median {statistics.median(rs):.2f}x)"


def kernels_conclusions(records: list[dict], ref: dict) -> list[str]:
    """Speed-up ratios from the interleaved timings: each run timed its form against the compiled per-effect
    kernels batch by batch (speedup_vs_ref), so a ratio of two forms divides two same-moment measurements."""
    ok = {(r["element"], r["form"], r["split"], int(r["gauss"])): r for r in records
          if r.get("success") and r.get("error") is not None and r.get("speedup_vs_ref")}
    rel = {k: r["speedup_vs_ref"] for k, r in ok.items()}
    lines = []
    vm, fu = {s: [] for s in SPLITS}, {f: [] for f in FORMS}
    for (el, form, split, g), x in rel.items():
        if form == "compiled" and (el, "sx_vm", split, g) in rel:
            vm[split].append(x / rel[(el, "sx_vm", split, g)])
        if split == "fused" and (el, form, "per_effect", g) in rel:
            fu[form].append(x / rel[(el, form, "per_effect", g)])
    for split in SPLITS:
        if vm[split]:
            lines.append(f"compiled vs SX VM ({split.replace('_', '-')} kernels): the compiled kernel is "
                         f"{_ratio_text(vm[split])} faster over {len(vm[split])} (element, Gauss order) pair(s)")
    for form in FORMS:
        if fu[form]:
            lines.append(f"fused vs per-effect ({form.replace('_', ' ')}): per-effect time / fused time = "
                         f"{_ratio_text(fu[form])} over {len(fu[form])} pair(s) (> 1: the fused kernel is faster)")
    for el in ELEMENTS:
        gs = sorted({g for (e, _, _, g) in rel if e == el})
        if not gs:
            continue
        g = 5 if 5 in gs else gs[len(gs) // 2]
        cells = [(f, s, ok[(el, f, s, g)]) for f in FORMS for s in SPLITS if (el, f, s, g) in ok]
        parts = [f"{f.replace('_', ' ')} {s.replace('_', '-')} {r.get('ns_norm', r['ns_min']):.0f} "
                 f"({r['speedup_vs_ref']:.2f}x)"
                 for f, s, r in cells]
        within = [(r["speedup_vs_ref"], f, s) for f, s, r in cells if r["error"] <= TARGET]
        best = f"; fastest within {TARGET:g}: {max(within)[1]} {max(within)[2].replace('_', '-')}" if within else ""
        src = ok.get((el, "compiled", "fused", g), {}).get("source")
        lines.append(f"{el}, Gauss {g}: ns per element, load-normalised (speed-up vs compiled per-effect, timed "
                     "interleaved): "
                     + ", ".join(parts) + best + (f"; compiled fused kernel: {src}" if src else ""))
        base = ref.get("baseline_ns") or {}
        refs = {int(k.split(",")[1]): t for k, t in base.items() if k.split(",")[0] == el}
        if len(refs) > 1:
            lo, hi = min(refs), max(refs)
            lines.append(f"{el}, compiled per-effect kernels vs Gauss order (the reference's baseline, timed back to "
                         "back): " + ", ".join(f"{gg} points {t:.0f} ns" for gg, t in sorted(refs.items())) +
                         f" ({hi}/{lo} points = {hi / lo:.2f}, time ratio {refs[hi] / refs[lo]:.2f})")
    self_t = [r["speedup_vs_ref"] for (el, f, s, g), r in ok.items() if (f, s) == ("compiled", "per_effect")]
    if self_t:
        lines.append(f"timing noise: the reference timed interleaved against itself gives {_ratio_text(self_t)} "
                     "(ideal 1.00)")
    worst = max((r["raw_diff"] for r in ok.values()), default=None)
    if worst is not None:
        lines.append(f"every form agrees with the compiled per-effect kernels to {worst:.1e} (largest relative "
                     "difference of energy, gradient or Hessian): the same function up to round-off")
    return lines


_TIMING = ("CPU seconds of this process (time.process_time: preemption by other processes does not count) per "
           "element evaluation (energy + gradient + Hessian), the kernel(s) mapped over 1000 elements "
           "(200 in --quick) with Function.map and called through Function.buffer(); min over 50 batches of >= 5 ms "
           "(10 of >= 2 ms in --quick: on a shared machine many short batches catch more undisturbed ones than a "
           "few long ones); per-effect kernels called back to back; each batch alternates with one of "
           "the compiled per-effect kernels (ref_ns_min; speedup_vs_ref = ref_ns_min / ns_min compares same-moment "
           "measurements). wall_s (the figure, the answer) is load-normalised: ns_norm = ns_min x (the compiled "
           "per-effect kernels' time measured once before the runs) / ref_ns_min; ns_min is the raw time. Build and "
           "compile time not included (column build_s)")

STUDIES = [
    Study("kernels", "Kernel level: compiled vs CasADi SX virtual machine, fused vs per-effect kernels",
          (Axis("element", ELEMENTS, ("cable2d",), str, ELEMENTS, "element kind"),
           Axis("form", FORMS, FORMS, str, FORMS, "compiled C (casadi.external) or CasADi's SX virtual machine"),
           Axis("split", SPLITS, SPLITS, str, SPLITS, "one kernel per effect or one fused kernel"),
           Axis("gauss", (3, 5, 7), (5,), int, GAUSS_ORDERS, "Gauss points per element")),
          kernels_run, kernels_reference, kernels_error,
          "relative difference (e, g, H) to compiled per-effect", TARGET,
          columns=("ns_norm", "ns_min", "ns_median", "ref_ns_min", "speedup_vs_ref", "sx_ops", "kernels", "build_s",
                   "diff_energy", "diff_gradient", "diff_hessian", "raw_diff", "source"),
          refine_axis="gauss", conclusions=kernels_conclusions, max_jobs=1,
          extra={"timing": _TIMING, "time_label": "CPU time per element evaluation [s] (load-normalised)"},
          notes="Time per element evaluation (energy, gradient and Hessian together) of the same element energies "
                "in four forms: the compiled C kernels shipped with the package (`compiled`) or the same symbolic "
                "kernels evaluated by CasADi's SX virtual machine (`sx_vm`), with one kernel per effect "
                "(`per_effect`: cables axial_green + bending, beam3d the elastic-line forces line_strain + "
                "line_bending + line_torsion) or one fused kernel for all of them (`fused`). A compiled fused kernel "
                "comes from the installed package when it ships one (the cables' internal `elastic_green`), "
                "otherwise it is generated and compiled with gcc here (beam3d always; column `source`). States: "
                "random deformed elements (0.5 m, positions perturbed by 0.05 m, gradients by 0.1 rms), a 20 x 30 mm "
                "steel section. Every form computes the same function, so the error is round-off only; it is "
                "floored at 1.1e-16 (half an ulp; `raw_diff` keeps the raw figure, 0 for the reference itself). "
                "The figures' time axis is seconds per element (load-normalised, see Time); the second figure "
                "shows the differences at each Gauss order (round-off at all of them, no convergence to fit); "
                "the answer line ranks all elements together, the per-element lines below name each element's fastest "
                "form."),
]
