"""The kernel-level study: compiled vs CasADi SX virtual machine, fused vs per-effect kernels.

Every form evaluates the same element energy, gradient and Hessian; they differ only in the order of the floating
point operations (the fused kernel sums the axial and bending densities before differentiating, the per-effect
kernels sum their outputs; the SX VM runs the compiled kernel's instruction list). The kernels hold about 3e3
(cable2d) to 2.5e4 (beam3d) operations, so the round-off bound on any output relative to its largest entry is about
(operations in a dependency chain) x eps <= 1e4 x 1.1e-16 ~ 1e-12: that is the tolerance (measured: <= 4e-16). A
wrong kernel is far outside it (a kernel at another Gauss order differs by > 1e-6, tested below).
"""
from __future__ import annotations

import csv

import casadi as ca
import numpy as np
import pytest

from ancf_sym import kernels
from ancf_sym.study import get_study, run_study
from ancf_sym.study import kernel_studies as ks

ROUND_OFF = 1e-12


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("kernels_study")
    return run_study("kernels", out, quick=True, jobs=1, progress=False)


def test_quick_study_runs_every_form(quick):
    assert quick.complete and len(quick.records) == 4
    by = {(r["form"], r["split"]): r for r in quick.records}
    assert set(by) == {(f, s) for f in ks.FORMS for s in ks.SPLITS}
    for key, r in by.items():
        assert r["success"], (key, r["status"])
        assert r["ns_min"] > 0 and r["wall_s"] == pytest.approx(r["ns_norm"] * 1e-9)  # load-normalised time
        assert r["ns_norm"] == pytest.approx(r["ns_min"] * quick.reference["baseline_ns"]["cable2d,5"] / r["ref_ns_min"])


def test_every_form_is_the_same_function_to_round_off(quick):
    for r in quick.records:
        worst = max(r["diff_energy"], r["diff_gradient"], r["diff_hessian"])
        assert worst <= ROUND_OFF, (f"{r['element']} {r['form']} {r['split']}: energy/gradient/Hessian differ from "
                                    f"the compiled per-effect kernels by {worst:.2e} relative (round-off <= 1e-12)")
        assert r["error"] == pytest.approx(max(worst, ks.FLOOR))
    ref = next(r for r in quick.records if (r["form"], r["split"]) == ("compiled", "per_effect"))
    assert ref["raw_diff"] == 0.0  # the reference against itself


def test_report_files(quick):
    out = quick.out
    for f in ("report.md", "results.csv", "error_vs_time.png", "error_vs_gauss.png", "reference.json"):
        assert (out / f).is_file(), f
    rows = list(csv.DictReader(open(out / "results.csv")))
    assert len(rows) == 4 and {"form", "split", "ns_min", "source", "raw_diff"} <= set(rows[0])
    text = (out / "report.md").read_text()
    assert "## Answer" in text and "compiled vs SX VM" in text and "fused vs per-effect" in text
    assert "form = compiled" in quick.answer  # the fastest form within 1e-10 is a compiled one
    assert "Observed convergence rate" not in text  # round-off differences: no rate is fitted


def test_compiled_beats_the_sx_virtual_machine(quick):
    """Measured 7-20x on 2 shared cores; 1.5x holds on a loaded machine. Each run timed its form interleaved with
    the compiled per-effect kernels (speedup_vs_ref), so the ratio compares same-moment measurements."""
    rel = {(r["form"], r["split"]): r["speedup_vs_ref"] for r in quick.records}
    for split in ks.SPLITS:
        ratio = rel[("compiled", split)] / rel[("sx_vm", split)]
        assert ratio >= 1.5, f"{split}: compiled kernel only {ratio:.2f}x faster than the SX VM (expected >= 1.5x)"
    assert 1 / rel[("sx_vm", "per_effect")] >= 1.5  # the SX VM per-effect kernels vs the compiled ones, directly


def test_conclusions_state_the_ratios(quick):
    lines = get_study("kernels").conclusions(quick.records, quick.reference)
    text = "\n".join(lines)
    assert "the compiled kernel is" in text and "x faster" in text and "per-effect time / fused time" in text
    assert "ns per element" in text


def test_fused_kernel_compiled_here_when_the_package_ships_none(monkeypatch):
    """The fallback of a clean install without fused kernels: generated and compiled with gcc at run time."""
    monkeypatch.setattr(ks, "installed_fused", lambda element, gauss: None)
    r = ks.kernels_run({"element": "cable2d", "form": "compiled", "split": "fused", "gauss": 5}, "quick")
    assert r["source"].startswith("generated and compiled here")
    assert r["raw_diff"] <= ROUND_OFF


def test_beam3d_fused_elastic_line_kernel():
    """beam3d fused = one point function with line_strain + line_bending + line_torsion (built and compiled here)."""
    for form in ks.FORMS:
        r = ks.kernels_run({"element": "beam3d", "form": form, "split": "fused", "gauss": 3}, "quick")
        assert r["success"] and r["kernels"] == 1
        assert r["raw_diff"] <= ROUND_OFF, (form, r["raw_diff"])


def test_the_error_measure_sees_a_wrong_kernel():
    """Fused kernel at 3 Gauss points vs per-effect at 5: a real difference, far above the round-off tolerance."""
    q = ks.element_states("cable2d", 50)
    ref = ks.summed_outputs(ks.mapped([(ca.Function(kernels.load("cable2d", e, 5)), kernels.parameters("cable2d", e))
                                       for e in ks.PARTS["cable2d"]], q))
    f3 = ks.build_form("cable2d", "sx_vm", "fused", 3)
    got = ks.summed_outputs(ks.mapped(f3["fns"], q))
    d = ks.relative_differences(got, ref)
    assert min(d.values()) > 1e-6 > ROUND_OFF, d
    assert np.all(np.isfinite(got[2]))
