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


@pytest.mark.parametrize("element, effect", [("cable2d", "contact_ground_friction"), ("cable2d", "contact_drum_friction"),
                                             ("cable2d", "contact_body_friction"), ("cable3d", "contact_ground_friction")])
def test_rows_kernel_is_the_hessians_force_rows(element, effect):
    """The step's friction kernel (<name>_rows: force and [df/dq, df/dv]) gives the v-part of the full kernel's
    gradient and the v-rows of its Hessian: the same SX graph restricted to those outputs, so the same numbers
    entry for entry (compared to 1e-14 relative: the two are compiled as separate C functions)."""
    import casadi as ca

    from ancf_sym import kernels, registry

    n = registry.input_size(element, effect) // 2
    params = registry.EFFECTS[(element, effect)].params
    rng = np.random.default_rng(3)
    p = {"L": 0.1, "k": 1e4, "kh": 1e5, "t": 0.005, "c": 30.0, "mu": 0.3, "eps": 1e-3, "R": 0.3, "d": 0.0,
         "nx": 0.0, "ny": 1.0, "nz": 0.0, "ax": 0.0, "ay": 0.0, "az": 1.0}
    P = np.array([p.get(k, 0.0) for k in params])
    full, rows = kernels.load(element, effect), kernels.load_rows(element, effect)
    checked = 0
    for _ in range(5):
        z = rng.normal(scale=0.3, size=2 * n)
        _, g, H = (np.asarray(o) for o in full(z, P))
        f, J = (np.asarray(o) for o in rows(z, P))
        scale = max(1.0, np.abs(H).max())
        assert np.allclose(f.ravel(), g.ravel()[n:], rtol=0, atol=1e-14 * max(1.0, np.abs(g).max()))
        assert np.allclose(J, H[n:, :], rtol=0, atol=1e-14 * scale)
        checked += np.abs(J).max() > 0
    assert checked  # some states penetrate (nonzero force and tangents), not only zeros


def test_run_without_energies_skips_work_booking_only():
    """energies=False skips the damping and load work (the energy balance is all that reads it): the motion of a
    rope sliding on the ground with friction is the same, bit for bit."""
    sc = _scene("ground", 0.005 - 1000 * np.pi * 0.005 ** 2 * 9.81 / 1e4)  # at its static penetration
    from ancf_sym.model.assembly import Assembly

    v = np.zeros(Assembly(sc).n)
    v[0::4] = 1.0
    a = simulate(sc, DynamicOptions(dt=1e-3, t_end=0.1, v0=v))
    b = simulate(sc, DynamicOptions(dt=1e-3, t_end=0.1, v0=v, energies=False))
    assert a.success and b.success
    assert float(np.abs(a.energies["damping_work"]).max()) > 0 and not b.energies
    assert np.array_equal(a.x, b.x) and np.array_equal(a.v, b.v)


@pytest.mark.parametrize("kind", ["ground", "drum"])
def test_reach_bound_is_contact_gaps_hull_bound_3d(kind):
    """The free chunks' reach test (control points as one sparse product per contact) is contact_gap's Bezier hull
    bound, element by element (3D cable, a tilted ground, a drum of skew axis; random states): the same formula,
    so equal to round-off."""
    from ancf_sym.contact import gap as contact_gap
    from ancf_sym.model.assembly import Assembly
    from ancf_sym.system.step_system import StepSystem

    sc = Scene(dim=3, gravity=(0.0, 0.0, -9.81))
    sc.member("rope", [(0.0, 0.0, 0.05), (1.0, 0.2, 0.05)], 6, Material(E=2e9, density=1000.0), Section.circle(0.01))
    if kind == "ground":
        sc.contact_ground("rope", normal=(0.1, 0.0, 1.0), level=-0.1, **LAW)
    else:
        sc.contact_drum("rope", centre=(0.5, 0.0, -0.3), radius=0.3, axis=(0.0, 1.0, 0.2), **LAW)
    asm = Assembly(sc)
    S = StepSystem(asm)
    fc = reach.FreeChunks(S, None, None, None)
    rng = np.random.default_rng(4)
    Q = np.array([S.reduce(asm.x0) + 0.05 * rng.normal(size=S.nf) for _ in range(4)])
    got = fc._clearance(Q, np.zeros_like(Q))
    c = sc.contacts[0]
    X = S.full_rows(Q)
    A = contact_gap.cubic(asm, c, X)
    ref = []
    for i in range(len(Q)):
        Ai = A[i]
        if contact_gap.is_drum(c):
            centre, P = contact_gap.surfaces(asm, c, X[i:i + 1])
            Ai = contact_gap._relative(c, Ai, np.broadcast_to(centre[0], (len(Ai), 3)),
                                       np.broadcast_to(P[0], (len(Ai), 3, 3)))
        ref.append(contact_gap.gap_lower_bound(c, Ai).min() - fc.floor[0])
    assert np.allclose(got, ref, rtol=0, atol=1e-12)
    assert np.any(np.array(ref) < 0) or kind == "ground"  # (the drum states reach in and out)
