"""A contact scene's time loop runs its chunks on the step graph of the same scene without contacts while no element
is in reach of a surface (ancf_sym.dynamics.reach): the run is the one that evaluates every contact pair at every
step, to round-off, before, through and after touch-down, and an untouched contact runs entirely off its kernels."""
import numpy as np
import pytest

from ancf_sym import Material, Scene, Section
from ancf_sym.dynamics import DynamicOptions, reach, simulate

LAW = dict(stiffness=1e4, damping=3e4, mu=0.3, eps=1e-3)


def _scene(kind: str, y: float = 0.05) -> Scene:
    sc = Scene(dim=2, gravity=(0.0, -9.81))
    sc.member("rope", [(0.0, y), (1.0, y)], 12, Material(E=2e9, density=1000.0), Section.circle(0.01))
    if kind == "far":
        sc.contact_ground("rope", level=-10.0, **LAW)
    elif kind == "ground":
        sc.contact_ground("rope", **LAW)
    elif kind == "drum":
        sc.contact_drum("rope", centre=(0.5, -0.3), radius=0.3, **LAW)
    elif kind == "far_plain":
        pass
    return sc


def _pair(kind: str, y: float, t_end: float, monkeypatch):
    runs = []
    for on in (True, False):
        monkeypatch.setattr(reach, "ENABLED", on)
        r = simulate(_scene(kind, y), DynamicOptions(dt=1e-3, t_end=t_end))
        assert r.success, r.message
        runs.append(r)
    return runs


def _same(a, b, L: float = 1.0):
    """Both runs solve the same discrete equations (the laws are exactly 0 out of reach) with different linear
    solvers (banded LDL^T without contact, sparse QR with friction's unsymmetric tangent): each step's solution
    differs by round-off of the solves, ~1e-16 relative to the coordinates, amplified along the run by the stiff
    penalty and friction laws at most by their step-to-step condition; 1e-9 of the rope's length and of the
    largest speed bounds that with a wide margin and stays far below any physical difference (the Newton tolerance
    of a step is 1e-9 x L here)."""
    assert np.abs(a.x - b.x).max() <= 1e-9 * L
    assert np.abs(a.v - b.v).max() <= 1e-9 * max(1.0, np.abs(b.v).max())
    for k in b.energies:
        scale = max(1e-3, float(np.abs(b.energies[k]).max()))
        assert np.abs(a.energies[k] - b.energies[k]).max() <= 1e-9 * scale, k


def test_untouched_contact_runs_off_its_kernels(monkeypatch):
    on, off = _pair("far", 0.05, 0.2, monkeypatch)
    assert on.steps_out_of_reach == on.steps == 200  # every chunk on the contact-free graph
    assert off.steps_out_of_reach == 0
    _same(on, off)
    plain = simulate(_scene("far_plain"), DynamicOptions(dt=1e-3, t_end=0.2))
    _same(on, plain)  # and it is the plain rope's motion


@pytest.mark.parametrize("kind, y, t_end", [("ground", 0.05, 0.3), ("drum", 0.3, 0.4)])
def test_touchdown_is_never_missed(kind, y, t_end, monkeypatch):
    """The rope falls onto the surface: the free chunks stop before the first iterate in reach (free fall to the
    touch-down: 96 ms from 4.5 cm onto the ground, 0.24 s from 29.5 cm onto the drum), the contact graph takes
    over, and the motion through the impact and after it (friction, damping) is that of the all-pairs run."""
    on, off = _pair(kind, y, t_end, monkeypatch)
    touchdown = np.sqrt(2 * (y - 0.005) / 9.81)
    assert 0.5 * touchdown <= on.steps_out_of_reach * 1e-3 <= touchdown
    assert float(np.abs(off.energies["damping_work"]).max()) > 0  # the contact's friction and damping did work
    _same(on, off)
