"""Dynamics studies: paper 000's beam released horizontal (clamped) and paper 002's soft rope (pinned),
integrator x time step x elements, against a converged run (finer mesh and step, 3-stage Radau IIA)."""
from __future__ import annotations

import time

import numpy as np

from ancf_sym.study.base import Axis, Study

INTEGRATORS = ("newmark", "hht", "generalized_alpha", "radau", "gauss")
OUTPUT_DT = 0.01  # the tip is compared at these times


def _tip_history(scene, integrator: str, dt: float, t_end: float, member: str,
                 progress=None) -> tuple[dict, np.ndarray]:
    from ancf_sym.dynamics import run_dynamics
    t0 = time.perf_counter()
    r = run_dynamics(scene, {"integrator": integrator, "dt": dt, "t_end": t_end, "output_dt": OUTPUT_DT,
                             "energies": False,
                             "sensors": [{"name": "tip", "kind": "position", "member": member, "at": "end"}]},
                     progress)
    total = time.perf_counter() - t0
    rec = {"status": r.status, "success": bool(r.success), "wall_s": total, "loop_s": r.wall_s, "setup_s": r.setup_s,
           "steps": r.steps, "newton_iterations": r.newton_iterations, "factorizations": r.factorizations}
    return rec, (r.sensors["tip"] if r.success else None)


def _history_error(rec: dict, ref: dict) -> float:
    """max_t |tip(t) - tip_ref(t)| / max_t |tip_ref(t) - tip_ref(0)| over the output times."""
    a, b = np.asarray(rec["tip"]), np.asarray(ref["tip"])
    if a.shape != b.shape:
        return float("inf")
    scale = float(np.max(np.linalg.norm(b - b[0], axis=1)))
    return float(np.max(np.linalg.norm(a - b, axis=1)) / scale)


def _richardson(fine: np.ndarray, coarse: np.ndarray, p: float) -> np.ndarray:
    """Richardson extrapolation in the mesh: fine + (fine - coarse) / (2^p - 1) (coarse: half the elements)."""
    return fine + (fine - coarse) / (2.0 ** p - 1.0)


def _reference(scene_fn, n: int, dt: float, t_end: float, member: str, parts=None) -> dict:
    """Radau IIA (3 stages, order 5) at n/4, n/2 and n elements (dt), Richardson-extrapolated in the mesh with
    the order observed on the three meshes; and at (n, 2 dt). Its error bound is the larger of the change of the
    extrapolated history from n/2 to n, and the change from 2 dt to dt at n: each overstates the reference's
    own error (the extrapolation converges faster than either run; the difference to 2 dt is (2^5 - 1) times
    the step error of dt).

    parts (runner.ReferenceParts): each of the four runs is announced with its simulated-time progress and stored
    as it finishes (a resumed study reuses them); the cheapest runs go first, so that the first progress comes
    soon."""
    runs = {}
    plan = {"n/4": (n // 4, dt), "n/2": (n // 2, dt), "2dt": (n, 2 * dt), "n": (n, dt)}
    if parts is not None:
        parts.total = len(plan)
    for key, (nn, h) in plan.items():
        def compute(report, state=None, save=None, nn=nn, h=h) -> dict:
            return _segmented_history(scene_fn(nn), h, t_end, member, report, state, save)
        label = f"Radau IIA, n = {nn}, dt = {h:g} s, {t_end:g} s simulated"
        rec = compute(None) if parts is None else parts.run(f"radau_n{nn}_dt{h:g}", label, compute, span=t_end,
                                                            checkpoints=True)
        if not rec["success"]:
            return {"success": False, "status": f"{rec['status']} (radau, n = {nn}, dt = {h:g})"}
        runs[key] = np.asarray(rec["tip"])
    d1 = float(np.max(np.linalg.norm(runs["n/2"] - runs["n/4"], axis=1)))
    d2 = float(np.max(np.linalg.norm(runs["n"] - runs["n/2"], axis=1)))
    p = float(np.clip(np.log2(d1 / d2), 1.0, 6.0)) if d2 > 0 and d1 > 0 else 4.0
    tip = _richardson(runs["n"], runs["n/2"], p)
    ref = {"tip": tip.tolist()}
    bound = max(_history_error({"tip": _richardson(runs["n/2"], runs["n/4"], p).tolist()}, ref),
                _history_error({"tip": runs["2dt"].tolist()}, {"tip": runs["n"].tolist()}))
    return {"success": True, "tip": ref["tip"], "error_bound": bound, "mesh_order": p,
            "unextrapolated_error": _history_error({"tip": runs["n"].tolist()}, ref),
            "how": f"3-stage Radau IIA, dt = {dt:g} s, Richardson-extrapolated in the mesh from n = {n // 2} and "
                   f"{n} elements (order {p:.2f} observed with n = {n // 4}, {n // 2}, {n}); error estimated by the "
                   f"same extrapolation from n = {n // 4} and {n // 2}, and by a run with 2 dt"}


REFERENCE_SEGMENTS = 10  # checkpoints of a reference run: an interrupt loses at most a tenth of it


def _segmented_history(scene, dt: float, t_end: float, member: str, report=None, state: dict | None = None,
                       save=None) -> dict:
    """A Radau IIA run of the reference in REFERENCE_SEGMENTS pieces of whole steps, each starting from the
    previous piece's end state (coordinates and velocities: a one-step method with a fixed step continues exactly
    as one run would, up to the Newton tolerance of each step); save(state) after each piece, `state` the piece to
    resume from. The record: status, counters summed, the tip at every output time."""
    from ancf_sym.dynamics import DynamicOptions, run_dynamics
    steps = int(round(t_end / dt))
    cuts = [round(k * steps / REFERENCE_SEGMENTS) for k in range(REFERENCE_SEGMENTS + 1)]
    cuts = sorted(set(c for c in cuts if c % max(1, int(round(OUTPUT_DT / dt))) == 0) | {0, steps})
    st = state or {"piece": 0, "tip": [], "x": None, "v": None,
                   "rec": {"status": "completed", "success": True, "wall_s": 0.0, "loop_s": 0.0, "setup_s": 0.0,
                           "steps": 0, "newton_iterations": 0, "factorizations": 0}}
    sensor = [{"name": "tip", "kind": "position", "member": member, "at": "end"}]
    for k in range(st["piece"], len(cuts) - 1):
        t0, t1 = cuts[k] * dt, (cuts[k + 1] * dt if cuts[k + 1] < steps else t_end)
        opts = DynamicOptions(integrator="radau", dt=dt, t_start=t0, t_end=t1, output_dt=OUTPUT_DT, energies=False,
                              sensors=sensor, q0=None if st["x"] is None else np.asarray(st["x"]),
                              v0=None if st["v"] is None else np.asarray(st["v"]))
        w0 = time.perf_counter()
        r = run_dynamics(scene, opts, None if report is None else (lambda t, _end: report(t)))
        rec = dict(st["rec"])
        rec["wall_s"] += time.perf_counter() - w0
        rec["loop_s"] += r.wall_s
        rec["setup_s"] += r.setup_s
        rec["steps"] += r.steps
        rec["newton_iterations"] += r.newton_iterations
        rec["factorizations"] += r.factorizations
        if not r.success:
            return {**rec, "status": r.status, "success": False, "tip": None}
        tip = np.asarray(r.sensors["tip"]).tolist()
        st = {"piece": k + 1, "tip": st["tip"] + (tip if k == 0 else tip[1:]), "x": r.x.tolist(), "v": r.v.tolist(),
              "rec": rec}
        if save is not None and k + 2 < len(cuts):
            save(st)
    return {**st["rec"], "tip": st["tip"]}


def _run(scene_fn, member: str, t_end: float):
    def run(setting: dict, variant: str) -> dict:
        rec, tip = _tip_history(scene_fn(setting["n"]), setting["integrator"], setting["dt"], t_end, member)
        if tip is not None:
            rec["tip"] = tip.tolist()
        return rec
    return run


def _conclusions(records: list[dict], ref: dict) -> list[str]:
    """Per integrator: the cheapest run within the target, and the cost of each halving of the error."""
    lines = []
    ok = [r for r in records if r.get("error") is not None]
    for integ in INTEGRATORS:
        rs = sorted((r for r in ok if r["integrator"] == integ), key=lambda r: r["error"])
        if rs:
            b = rs[0]
            lines.append(f"{integ}: smallest error {b['error']:.2e} (n = {b['n']}, dt = {b['dt']:g}) in "
                         f"{b['wall_s']:.3g} s, {b['steps']} steps, {b['newton_iterations']} Newton iterations")
    failed = [r for r in records if not r.get("success")]
    if failed:
        lines.append("failed settings: " + "; ".join(f"{r['integrator']} n = {r['n']} dt = {r['dt']:g}: {r['status']}"
                                                     for r in failed))
    return lines


# -- paper 000 beam released horizontal -----------------------------------------------------------------------------
ZL, ZA, ZI, ZRHO, ZE, ZG, ZT = 3.0, 7.854e-5, 4.909e-10, 7200.0, 20e9, 9.81, 1.0


def zhang_scene(n: int):
    from ancf_sym.scene.builder import Material, Scene, Section
    s = Scene(dim=2, gravity=(0.0, -ZG), name="zhang_pendulum")
    s.member("beam", points=[(0.0, 0.0), (ZL, 0.0)], elements=n, material=Material(E=ZE, density=ZRHO),
             section=Section(area=ZA, I=ZI), axial="decoupled", bending=True, gravity=True)
    s.clamp("beam", at="start")
    return s


# -- paper 002 soft rope ----------------------------------------------------------------------------------------------
RL, RA, RI, RRHO, RE, RG, RT = 1.2, 0.0018, 1.215e-8, 5540.0, 0.7e6, 9.81, 1.0


def rope_scene(n: int):
    from ancf_sym.scene.builder import Material, Scene, Section
    s = Scene(dim=2, gravity=(0.0, -RG), name="rope_fall")
    s.member("rope", points=[(0.0, 0.0), (RL, 0.0)], elements=n, material=Material(E=RE, density=RRHO),
             section=Section(area=RA, I=RI), axial="green", bending=True, gravity=True)
    s.pin("rope", at="start")
    return s


_INTEG = Axis("integrator", INTEGRATORS, ("newmark", "generalized_alpha", "radau"), str, INTEGRATORS)
_DT = Axis("dt", (4e-3, 2e-3, 1e-3, 5e-4), (4e-3, 2e-3), float)
_TIMING = ("run_dynamics wall time: building the compiled step graph + the time loop (tip recorded every 0.01 s, "
           "no energy bookkeeping), one run per setting")


def _study(name: str, title: str, scene_fn, member: str, t_end: float, ns: tuple, quick_ns: tuple,
           ref_n: tuple[int, int], ref_dt: tuple[float, float], target: float, notes: str) -> Study:
    """A dynamics study; ref_n / ref_dt: the reference's (quick, full) mesh and step."""
    def reference(variant: str, parts=None) -> dict:
        k = 0 if variant == "quick" else 1
        return _reference(scene_fn, ref_n[k], ref_dt[k], t_end, member, parts)

    return Study(name, title, (_INTEG, _DT, Axis("n", ns, quick_ns, int)), _run(scene_fn, member, t_end), reference,
                 _history_error, "max tip position error / max tip displacement", target,
                 columns=("loop_s", "setup_s", "steps", "newton_iterations", "factorizations"),
                 conclusions=_conclusions, extra={"timing": _TIMING}, notes=notes, step_axis="dt")


STUDIES = [
    _study("zhang_pendulum", "Paper 000 beam released horizontal, clamped (1 s)", zhang_scene, "beam", ZT,
           (3, 6, 12, 24), (3, 6), (12, 96), (5e-4, 1.25e-4), 1e-3,
           "Paper 000 section 3.2 (its table 2 beam: L = 3 m, E = 20 GPa), clamped at x = 0 and released "
           "horizontal under gravity, decoupled strain, 1 s (the fall and curl to the first extremum). "
           "HHT alpha = -0.05, generalized-alpha rho_inf = 0.9, Radau IIA 3 stages, Gauss-Legendre 2 stages."),
    _study("rope", "Paper 002 soft rope pinned and released (1 s)", rope_scene, "rope", RT,
           (8, 16, 32), (8, 16), (32, 512), (5e-4, 2.5e-4), 1e-2,
           "Paper 002's soft rope (L = 1.2 m, A = 0.0018 m^2, I = 1.215e-8 m^4, rho = 5540 kg/m^3, E = 0.7 MPa: "
           "up to ~30 % stretch), pinned at x = 0 and released horizontal, Green strain, 1 s. Default target 1e-2: the "
           "rope's motion is sensitive (folds travelling along it), 1 % of the tip's travel is ~1.5 cm."),
]
