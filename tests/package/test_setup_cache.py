"""The numeric set-up kept by exact inputs (ancf_sym.util.setup_cache): a second run of a structure with other values
(E, dt, loads, initial state, density, supports) gives exactly what a first run of those values gives in a fresh
process, the cached pieces are shared read-only, and clear_graph_cache() forgets them."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp

from ancf_sym import Material, Scene, Section
from ancf_sym.util import setup_cache
from ancf_sym.model.assembly import Assembly
from ancf_sym.model.constraints import _csr, _take_rows
from ancf_sym.dynamics import DynamicOptions, StepSystem, clear_graph_cache, simulate
from ancf_sym.model.reduced import partition

BASE = dict(n=6, E=2e9, I=1e-9, rho=7200.0, g=9.81, dt=1e-3, force=(0.0, -1.0), v0=0.0, support="pin")
# one value changed at a time (the cache keys on E and I through nothing, on rho through the mass matrix, on the
# support through the constraints and the partition; dt, loads and the initial state are run inputs)
VARIANTS = {"base": {}, "E": dict(E=4e9), "I": dict(I=3e-9), "dt": dict(dt=5e-4), "gravity": dict(g=5.0),
            "force": dict(force=(0.5, -2.0)), "v0": dict(v0=0.2), "density": dict(rho=2000.0),
            "support": dict(support="clamp")}


def run_variant(name: str) -> dict:
    """A 0.1 s run of a pendulum (100 steps: two compiled 50-step chunks) with the variant's values."""
    c = dict(BASE, **VARIANTS[name])
    s = Scene(dim=2, gravity=(0.0, -c["g"]))
    s.member("m", [(0.0, 0.0), (1.0, 0.0)], c["n"], Material(E=c["E"], density=c["rho"]),
             Section(area=1e-4, I=c["I"]), axial="biot")
    (s.clamp if c["support"] == "clamp" else s.pin)("m", "start")
    s.force("m", "end", c["force"])
    asm = Assembly(s)
    S = StepSystem.for_scene(asm)
    v0 = np.zeros(asm.n)
    v0[1::4] = np.linspace(0.0, c["v0"], asm.n // 4)  # (zero at the support: pin and clamp both allow it)
    opts = DynamicOptions(dt=c["dt"], t_end=0.1, integrator="generalized_alpha", rho_inf=0.9, v0=v0,
                          output_dt=0.02, sensors=[{"name": "tip", "kind": "position", "member": "m", "at": "end"}])
    res = simulate(asm, opts, system=S)
    assert res.status == "completed", res.message
    return {"tip": res.sensors["tip"].tolist(), "x": res.x.tolist(), "v": res.v.tolist(),
            "energies": {k: np.asarray(v).tolist() for k, v in res.energies.items()},
            "mass_cached": setup_cache.key_of(S.M_full) is not None, "mass_id": id(S.M_full),
            "graph_key": S.graph_key}


def main(mode: str, names: list[str]) -> None:
    """warm: the variants one after the other in this process (every later run a second run, caches kept);
    cold: each variant after clear_graph_cache() (a first run)."""
    out = {}
    for name in names:
        if mode == "cold":
            clear_graph_cache()
        out[name] = run_variant(name)
    print(json.dumps(out))


def _spawn(mode: str, names: list[str], cwd: Path) -> subprocess.Popen:
    code = (f"import sys; sys.path.insert(0, {str(Path(__file__).parent)!r}); import test_setup_cache as t; "
            f"t.main({mode!r}, {names!r})")
    env = dict(os.environ, PYTHONHASHSEED="0")  # (the same dict and set orders in every process)
    return subprocess.Popen([sys.executable, "-c", code], cwd=cwd, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def _result(p: subprocess.Popen) -> dict:
    out, err = p.communicate(timeout=300)
    assert p.returncode == 0, err
    return json.loads(out.splitlines()[-1])


def test_second_runs_with_other_values_equal_fresh_first_runs(tmp_path):
    """Each variant run second in a warm process (the base structure's set-up cached) equals, to the last bit, a
    first run of the same values in a fresh process: a cache hit must be the very numbers a fresh computation gives
    (its keys hold the inputs themselves) and the compiled step graphs take E, loads, dt and the state as inputs.
    Bitwise, not to a tolerance: both sides run the same compiled code on the same numbers in the same order, so
    any difference is a stale input. Each variant also differs from the base (the changed value reached the run),
    and the runs that keep the mass inputs share the base's cached mass matrix (the cache was used)."""
    names = list(VARIANTS)
    warm = _spawn("warm", names, tmp_path)
    cold = [_spawn("cold", [name], tmp_path) for name in names]  # one fresh process per variant
    w = _result(warm)
    fresh = {}
    for p in cold:
        fresh.update(_result(p))
    base = w["base"]
    for name in names:
        for k in ("tip", "x", "v", "energies"):
            assert w[name][k] == fresh[name][k], (name, k)
        if name != "base":
            assert not np.array_equal(w[name]["tip"], base["tip"]), name
    for name in ("E", "I", "dt", "gravity", "force", "v0"):
        assert w[name]["mass_cached"] and w[name]["mass_id"] == base["mass_id"], name
        assert w[name]["graph_key"] == base["graph_key"], name  # the compiled graphs reused too
    for name in ("density", "support"):
        assert w[name]["graph_key"] != base["graph_key"], name


def _pendulum(rho=7200.0, E=2e9):
    s = Scene(dim=2, gravity=(0.0, -9.81))
    s.member("m", [(0.0, 0.0), (1.0, 0.0)], 6, Material(E=E, density=rho), Section(area=1e-4, I=1e-9),
             axial="biot")
    s.pin("m", "start")
    return s


def test_cached_pieces_are_shared_read_only_and_cleared_with_the_graphs():
    """The mass matrix and the partition of a scene with other E are the cached objects (no recomputation), with
    the entries a computation gives; their arrays refuse writes (another run shares them); clear_graph_cache()
    forgets them (the next scene computes them anew) and another density computes its own mass matrix."""
    clear_graph_cache()
    a = Assembly(_pendulum())
    M, part = a.mass_matrix(), partition(a)
    b = Assembly(_pendulum(E=5e9))
    assert b.mass_matrix() is M and partition(b) is part
    assert setup_cache.key_of(M) is not None and setup_cache.key_of(part) is not None
    with pytest.raises(ValueError):
        M.data[0] = 1.0
    with pytest.raises(ValueError):
        part.pos[0] = 0
    M2 = Assembly(_pendulum(rho=2000.0)).mass_matrix()
    assert M2 is not M and np.isclose(M2.sum(), M.sum() * 2000.0 / 7200.0, rtol=1e-12)  # mass linear in rho
    clear_graph_cache()
    assert setup_cache.key_of(M) is None and setup_cache.key_of(part) is None
    c = Assembly(_pendulum())
    Mc = c.mass_matrix()
    assert Mc is not M and partition(c) is not part
    assert (Mc != M).nnz == 0 and np.array_equal(Mc.indices, M.indices)


def test_constraint_rows_built_directly_equal_scipys_conversion():
    """The constraint matrix from (row, col, value) entries and its row subsets are built by numpy gathers; they
    must be SciPy's coo -> csr and fancy row indexing array for array (same entries, order and index types), on
    random patterns with empty rows and duplicate-free columns as the constraint builder makes them."""
    rng = np.random.default_rng(3)
    for _ in range(100):
        m, n = int(rng.integers(1, 8)), int(rng.integers(1, 30))
        lin = [(r, int(c), float(rng.normal())) for r in range(m)
               for c in rng.choice(n, int(rng.integers(0, min(n, 4) + 1)), replace=False)]
        a = np.array(lin, dtype=float).reshape(-1, 3)
        ref = sp.coo_matrix((a[:, 2], (a[:, 0].astype(int), a[:, 1].astype(int))), shape=(m, n)).tocsr()
        A = _csr(lin, m, n)
        assert A.shape == ref.shape and A.indices.dtype == ref.indices.dtype and A.indptr.dtype == ref.indptr.dtype
        assert np.array_equal(A.indptr, ref.indptr) and np.array_equal(A.indices, ref.indices)
        assert np.array_equal(A.data, ref.data)
        rows = rng.permutation(m)[:int(rng.integers(0, m + 1))]
        B, C = _take_rows(A, rows), A[rows]
        assert B.shape == C.shape and np.array_equal(B.indptr, C.indptr)
        assert np.array_equal(B.indices, C.indices) and np.array_equal(B.data, C.data)


def _same(a, b) -> bool:
    """Equal to the last bit: arrays (dtype, shape, bytes), sparse matrices, objects field by field, containers."""
    if sp.issparse(a) or sp.issparse(b):
        return type(a) is type(b) and _same((a.shape, a.indptr, a.indices, a.data), (b.shape, b.indptr, b.indices, b.data))
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return (isinstance(a, np.ndarray) and isinstance(b, np.ndarray) and a.dtype == b.dtype and a.shape == b.shape
                and a.tobytes() == b.tobytes())
    if isinstance(a, (list, tuple)):
        return type(a) is type(b) and len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    if isinstance(a, dict):
        return type(b) is dict and a.keys() == b.keys() and all(_same(v, b[k]) for k, v in a.items())
    if isinstance(a, float):
        return type(b) is float and a.hex() == b.hex()
    if hasattr(a, "__dict__") and not isinstance(a, type):
        return type(a) is type(b) and vars(a).keys() == vars(b).keys() and \
            all(_same(v, vars(b)[k]) for k, v in vars(a).items())
    return type(a) is type(b) and a == b


def _system(n=6, E=2e9, I=1e-9, rho=7200.0, g=9.81, support="pin", axial="biot", method="exact"):
    s = Scene(dim=2, gravity=(0.0, -g))
    s.member("m", [(0.0, 0.0), (1.0, 0.0)], n, Material(E=E, density=rho), Section(area=1e-4, I=I), axial=axial)
    (s.clamp if support == "clamp" else s.pin)("m", "start", method=method)
    s.force("m", "end", (0.0, -1.0))
    return StepSystem.for_scene(Assembly(s))


def test_systems_built_on_a_kept_structure_equal_fresh_ones():
    """A step system whose structure (reduced coordinates, mass matrix, kernel calls, scales, compiled graphs' key)
    comes from an earlier scene that differs only in element stiffness (E, I) or gravity's magnitude has every
    attribute of one built in a cleared process, to the last bit (exact keys of both compared), and the structure
    key computed anew equals the kept one: the values it leaves out reach the run only as graph inputs. The kept
    structure is used (the same partition object), and scenes that differ in structure (element count, support,
    axial strain, density, gravity switched off) or read the stiffness elsewhere (penalty supports) do not share it."""
    from ancf_sym.system.graph_cache import structure_key
    attrs = [k for k in StepSystem._STRUCTURE_ATTRS if k != "graph_key"] + \
        ["f_lin", "f_lin_full", "par", "lin", "lin_energy", "force_terms"]
    for variant in (dict(E=3e9), dict(I=2e-9), dict(g=5.0), dict(E=5e9, I=4e-9, g=20.0)):
        clear_graph_cache()
        base = _system()
        warm = _system(**variant)
        assert warm.part is base.part and warm.graph_key == base.graph_key, variant
        clear_graph_cache()
        fresh = _system(**variant)
        for k in attrs:
            assert _same(getattr(warm, k), getattr(fresh, k)), (variant, k)
        clear_graph_cache()  # (neither's pieces in the cache: both keys walk their contents)
        assert structure_key(warm) == structure_key(fresh)
        assert not np.array_equal(warm.par, base.par) or not np.array_equal(warm.f_lin, base.f_lin)
    clear_graph_cache()
    base = _system()
    for variant in (dict(n=7), dict(support="clamp"), dict(axial="green"), dict(rho=2000.0), dict(g=0.0)):
        other = _system(**variant)
        assert other.asm.spec_key != base.asm.spec_key and other.graph_key != base.graph_key, variant
    assert _system(method="penalty").asm.spec_key is None  # (EA, EI scale the penalty rows)


def _kind_scene(kind: str, E: float = 2e9, I: float = 1e-9, g: float = 9.81) -> Scene:
    """Small scenes of the kinds a kept structure must serve: beams (two methods), a 3D cable with a moment,
    members joined rigidly or by a hinge, a polyline under a distributed load, Rayleigh and strain-rate damping."""
    s = Scene(dim=3, gravity=(0.0, 0.0, -g)) if kind in ("beam3d", "elastic_line", "cable3d") else \
        Scene(dim=2, gravity=(0.0, -g))
    mat, sec = Material(E=E, density=7800.0), Section(area=1e-4, I=I)
    if kind in ("beam3d", "elastic_line"):
        s.member("m", [(0, 0, 0), (1, 0, 0)], 4, mat, Section.rectangle(0.02, 0.01), element="beam3d",
                 beam_method="continuum" if kind == "beam3d" else "elastic_line")
        s.clamp("m", "start")
    elif kind == "cable3d":
        s.member("m", [(0, 0, 0), (1, 0, 0)], 5, mat, sec, axial="green")
        s.pin("m", "start")
        s.moment("m", "end", (0.0, 0.5, 0.0))
    elif kind in ("rigid", "hinge"):
        s.member("a", [(0, 0), (1, 0)], 3, mat, sec, axial="biot")
        s.member("b", [(1, 0), (1.5, -1)], 3, mat, sec, axial="green")
        (s.clamp if kind == "rigid" else s.pin)("a", "start")
        (s.rigid if kind == "rigid" else s.hinge)(("a", "end"), ("b", "start"))
    else:
        s.member("m", [(0, 0), (1, 0), (1.5, -0.5)], 6, mat, sec, axial="decoupled" if kind == "polyline" else "biot")
        s.clamp("m", "start")
        if kind == "polyline":
            s.distributed("m", (0.0, -3.0))
        elif kind == "rayleigh":
            s.rayleigh(alpha=0.1, beta=1e-4)
        else:
            s.strain_rate_damping(axial=10.0, bending=1e-3)
    return s


@pytest.mark.parametrize("kind", ["beam3d", "elastic_line", "cable3d", "rigid", "hinge", "polyline", "rayleigh",
                                  "strain_rate"])
def test_kept_structures_of_other_scene_kinds_equal_fresh_ones(kind):
    """As above on other kinds of scene (E x 1.5, I x 3, gravity 5 m/s^2 against the kept structure's scene): the
    structure is kept, every attribute and a 60-step run (states, Newton counters, energies) are bit for bit those of
    a fresh first run: the stiffnesses and gravity reach the run only as the graphs' inputs whatever the elements,
    joints, loads and damping."""
    other = dict(E=3e9, I=3e-9, g=5.0)
    opts = DynamicOptions(dt=1e-3, t_end=0.06, output_dt=0.02)
    clear_graph_cache()
    base = StepSystem.for_scene(Assembly(_kind_scene(kind)))
    warm = StepSystem.for_scene(Assembly(_kind_scene(kind, **other)))
    assert warm.part is base.part and warm.graph_key == base.graph_key
    kept = simulate(warm.asm, opts, system=warm)
    clear_graph_cache()
    fresh = StepSystem.for_scene(Assembly(_kind_scene(kind, **other)))
    attrs = [k for k in StepSystem._STRUCTURE_ATTRS if k != "graph_key"] + \
        ["f_lin", "par", "lin", "lin_energy", "force_terms", "rayleigh", "strain_rate"]
    for k in attrs:
        assert _same(getattr(warm, k), getattr(fresh, k)), k
    first = simulate(fresh.asm, opts, system=fresh)
    assert kept.status == first.status == "completed"
    assert np.array_equal(kept.x, first.x) and np.array_equal(kept.v, first.v) and kept.counters == first.counters
    assert all(np.array_equal(kept.energies[k], first.energies[k]) for k in first.energies)
    assert not np.array_equal(warm.par, base.par)  # (the other values reached the run)
