"""The command line, run as a user runs it: `python -m ancf_sym.cli ...` in a subprocess, outside the project root
(so that the installed package with its compiled kernels is imported)."""
from __future__ import annotations

import json
from pathlib import Path

import meshio
import numpy as np

from helpers import cli

ROOT = Path(__file__).resolve().parents[2]
CANTILEVER = ROOT / "examples" / "scenes" / "cantilever.toml"


def scene_variant(tmp_path: Path, name: str, old: str, new: str) -> Path:
    text = CANTILEVER.read_text()
    assert old in text
    p = tmp_path / name
    p.write_text(text.replace(old, new))
    return p


def test_run_writes_json_png_vtu_then_a_failed_run_keeps_them(tmp_path):
    out = tmp_path / "out" / "cantilever"
    r = cli("run", CANTILEVER, "--out", out, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert str(out) in r.stdout
    doc = json.loads((out / "result.json").read_text())
    assert doc["status"] == "Solve_Succeeded" and doc["success"] is True
    # the summary names the solver that produced the answer, as result.json does: Newton alone here, no IPOPT word
    assert doc["solver"]["path"] == "newton" and doc["solver"]["solved_by"].startswith("Newton (converged")
    assert f"solved by {doc['solver']['solved_by']}" in r.stdout and "IPOPT" not in r.stdout
    assert doc["scene"]["name"] == "cantilever" and doc["scene"]["file"] == str(CANTILEVER)
    assert set(doc["energies"]) == {"axial", "bending", "gravity"}
    assert doc["potential"] == sum(doc["energies"].values())
    assert abs(doc["potential"] + 11.493) < 2e-3
    assert doc["solver"]["iterations"] > 0 and doc["solver"]["attempts"][0]["method"] == "newton"
    assert 0 < doc["wall_s"]["solve"] <= doc["wall_s"]["total"] < 5.0
    assert doc["constraint_violation"] < 1e-9
    nodes = np.array(doc["members"]["beam"]["nodes"])
    assert nodes.shape == (19, 2) and np.allclose(nodes[0], 0) and nodes[-1, 1] < -2
    assert doc["members"]["beam"]["tip"] == doc["members"]["beam"]["nodes"][-1]
    assert {k["effect"] for k in doc["kernels"]} == {"axial_decoupled", "bending", "gravity"}
    for png in ("shape.png", "fields.png"):
        assert (out / png).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    mesh = meshio.read(out / "result.vtu")
    assert {"strain", "curvature", "s", "displacement"} <= set(mesh.point_data)
    assert len(mesh.points) == 18 * 8 + 1 and mesh.cells[0].type == "line"
    np.testing.assert_allclose(mesh.points[-1, :2], nodes[-1], atol=1e-12)
    assert (out / "scene.toml").read_text() == CANTILEVER.read_text()
    assert not list(out.parent.glob(".cantilever*")), "temporary directories left behind"

    # a failing run (IPOPT limited to one iteration): non-zero exit, one line, previous results untouched
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    bad = scene_variant(tmp_path, "one_iter.toml", 'type = "statics"', 'type = "statics"\nmax_iter = 1')
    r = cli("run", bad, "--out", out, "--quiet", cwd=tmp_path)
    assert r.returncode == 1
    assert "Traceback" not in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert "FAILED" in r.stderr and "kept" in r.stderr
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    failed = json.loads((out.parent / "cantilever.failed" / "result.json").read_text())
    assert failed["success"] is False and failed["status"] == "Maximum_Iterations_Exceeded"
    assert failed["analysis"]["max_iter"] == 1
    assert not list(out.parent.glob(".cantilever*")), "temporary directories left behind"


def test_bad_scene_exits_2_naming_the_field(tmp_path):
    bad = scene_variant(tmp_path, "bad.toml", "elements = 18", "elements = 0")
    out = tmp_path / "out"
    r = cli("run", bad, "--out", out, cwd=tmp_path)
    assert r.returncode == 2
    assert "members[0].elements" in r.stderr and "got 0" in r.stderr
    assert "Traceback" not in r.stderr and len(r.stderr.strip().splitlines()) == 1
    assert not out.exists() and not (tmp_path / "out.failed").exists()
    nan = scene_variant(tmp_path, "nan.toml", "density = 7200.0", "density = nan")
    r = cli("run", nan, "--out", out, cwd=tmp_path)
    assert r.returncode == 2 and "materials.paper000.density: must be finite" in r.stderr


def test_refuses_to_replace_a_directory_it_did_not_write(tmp_path):
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "notes.txt").write_text("keep me")
    r = cli("run", CANTILEVER, "--out", tmp_path / "mine", "--quiet", cwd=tmp_path)
    assert r.returncode == 2 and "not replacing" in r.stderr
    assert (tmp_path / "mine" / "notes.txt").read_text() == "keep me"


def test_kernels_table(tmp_path):
    r = cli("kernels", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert lines[0].split()[:4] == ["name", "element", "effect", "gauss"]
    assert any(l.split()[:3] == ["cable2d_bending", "cable2d", "bending"] for l in lines)
