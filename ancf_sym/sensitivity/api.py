"""Sensitivities of a scene's results by parameter path: the Python entry point and result.json's section.

`sensitivities(doc, paths)` solves the scene of a document (a TOML file or its parsed dict) and returns
{path: {"potential", "members": {NAME: {"nodes", "tip"}}, "constraint_forces": {LABEL: ...}}} with the keys and
shapes of the quantities differentiated (modal: also "frequencies"). Every path is checked before any solving.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ancf_sym.scene.builder import Scene
from ancf_sym.io.scene_toml import scene_from_dict
from ancf_sym.statics.problem import StaticResult, problem_for
from ancf_sym.sensitivity.exact_contact_geometry import geometry_path
from ancf_sym.sensitivity.model_derivative import check_model_paths, read_document
from ancf_sym.sensitivity.paths import get_parameter


def check_paths(scene: Scene, doc: dict, paths: list[str], analysis: dict | None = None,
                modes: int | None = None) -> None:
    """Refuse, before any solving, a path that names no differentiable number of this scene (KeyError /
    ValueError naming it), and a dynamics analysis whose sensitivities are not available (modes: frequencies asked
    for too)."""
    if analysis is not None and analysis.get("type") == "dynamics":
        from ancf_sym.sensitivity.dynamics import check_dynamic
        options = getattr(analysis, "options", None)  # (the TOML reader's decoded options, else the table's)
        if options is None:
            from ancf_sym.dynamics.options import options_from_dict
            options = options_from_dict(analysis)
        check_dynamic(scene, options)
        from ancf_sym.sensitivity.alpha_run import check_dynamic_paths  # (also dampings[i].alpha)
        check_dynamic_paths(scene, doc, paths, options=options)
        return
    if not (modes or (analysis is not None and analysis.get("type") == "modal")):
        # (an exact contact's geometry: the statics differentiate its rows themselves, exact_contact_geometry)
        for p in paths:
            get_parameter(doc, p)
        asm = problem_for(scene).asm
        paths = [p for p in paths if geometry_path(asm, doc, p) is None]
    check_model_paths(scene, doc, paths)


def sensitivities(doc: dict | str | Path, paths: list[str], result: StaticResult | None = None,
                  modes: int | None = None) -> dict:
    """{path: derivative dict} of the scene's static equilibrium (`result`, else solved here) and, with modes, of
    its lowest `modes` frequencies (key "frequencies", [Hz per unit of the parameter])."""
    from ancf_sym.sensitivity.modal import ModalSensitivity
    from ancf_sym.sensitivity.static import StaticSensitivity

    d = read_document(doc)
    scene, _ = scene_from_dict(d)
    check_paths(scene, d, list(paths), modes=modes)
    if result is None:
        result = problem_for(scene).solve()
    if not result.success:
        raise ValueError(f"sensitivities: the static solve failed ({result.status})")
    if modes:
        from ancf_sym.modal import modal_analysis
        m = modal_analysis(scene, modes=modes, static=result)
        ms = ModalSensitivity(m, scene, d)
        out = {}
        for p in paths:
            out[p] = ms.static.derivative(p)
            out[p]["frequencies"], notes = ms.derivative(p)
            if notes:
                out[p]["notes"] = notes
        return out
    s = StaticSensitivity(scene, result, d)
    return {p: s.derivative(p) for p in paths}


def to_json(sens: dict) -> dict:
    """The derivative dicts with arrays as lists (NaN as None), for result.json."""
    def conv(v):
        if isinstance(v, dict):
            return {k: conv(w) for k, w in v.items()}
        if isinstance(v, (list, tuple)) and any(isinstance(w, str) for w in v):  # (notes: text, kept)
            return [str(w) for w in v]
        if isinstance(v, (np.ndarray, list, tuple)):
            a = np.asarray(v, float)
            return [conv(w) for w in a] if a.ndim else conv(float(a))
        if isinstance(v, (float, np.floating)):
            v = float(v)
            return v if np.isfinite(v) else None
        return v
    return {p: conv(d) for p, d in sens.items()}


def add_to_result(result_file: Path, scene: Scene, scene_file: Path, analysis: dict, paths: list[str]) -> None:
    """Add `sensitivities` to a written result.json of a statics or modal run (the command line's
    --sensitivity): the equilibrium solved again with the run's options (the same deterministic answer)."""
    import json

    from ancf_sym.statics.problem import StaticOptions

    d = read_document(scene_file)
    kind = analysis["type"]
    if kind == "dynamics":
        _add_dynamic(result_file, d, analysis, paths)
        return
    skip = ("type", "modes", "damped")
    opts = StaticOptions(**{k: v for k, v in analysis.items() if k not in skip})
    res = problem_for(scene).solve(opts)
    sens = sensitivities(d, paths, res, modes=analysis.get("modes", 10) if kind == "modal" else None)
    from ancf_sym.io.json_out import write_json

    data = json.loads(result_file.read_text())
    data["sensitivities"] = to_json(sens)
    write_json(result_file, data, clean=False)


def _add_dynamic(result_file: Path, doc: dict, analysis: dict, paths: list[str]) -> None:
    """sensitivities[PATH] = {"t": the output times, "sensors": {NAME: d(record)/dp}} of a dynamics run, from its
    forward sensitivities (ancf_sym.sensitivity.dynamics) at its output times (ancf_sym.sensitivity.output_times)."""
    from ancf_sym.dynamics.options import options_from_dict
    from ancf_sym.io.json_out import write_json
    from ancf_sym.sensitivity.dynamics import dynamic_sensitivity
    from ancf_sym.sensitivity.output_times import at_times

    import json

    opts = options_from_dict(analysis)
    ds = dynamic_sensitivity(doc, paths, opts)
    data = json.loads(result_file.read_text())
    # (output times inside a step: the run's Hermite interpolant of the step's ends, differentiated exactly)
    times = np.asarray(data["t"], float)
    ds = at_times(ds, times, 1e-9 * opts.dt)
    out = {}
    for p in paths:
        entry: dict = {"t": times, "sensors": {}}
        for ev in ds.sensors:
            try:
                entry["sensors"][ev.sensor.name] = ds.sensor(p, ev.sensor.name)
            except ValueError as exc:  # (a kind not differentiated: named, not a silent gap)
                entry.setdefault("notes", []).append(str(exc))
        for note in ds.notes:  # (contact events: where the derivative is one-sided)
            entry.setdefault("notes", []).append(note)
        out[p] = entry
    data["sensitivities"] = to_json(out)
    write_json(result_file, data, clean=False)
