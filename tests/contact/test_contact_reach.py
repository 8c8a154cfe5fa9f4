"""The contact dissipation skips its kernels while no element is in reach of the surface (the contact_gap hull
bound at the iterate itself): the values it returns are those of evaluating every element-surface pair, bit for
bit, out of reach, at touch-down and in contact (the law is exactly 0 at a positive gap, so the switch changes no
value, only what is evaluated)."""
import casadi as ca
import numpy as np
import pytest

from ancf_sym import Material, Scene, Section
from ancf_sym.model.assembly import Assembly
from ancf_sym.system import damping
from ancf_sym.system.step_system import StepSystem
from ancf_sym.util.sparsity import dm

LAW = dict(stiffness=1e4, damping=3e4, mu=0.3, eps=1e-3)


def _scene(kind: str) -> Scene:
    sc = Scene(dim=2, gravity=(0.0, -9.81))
    sc.member("rope", [(0.0, 0.05), (1.0, 0.05)], 12, Material(E=2e9, density=1000.0), Section.circle(0.01))
    if kind == "ground":
        sc.contact_ground("rope", **LAW)
    else:
        sc.contact_drum("rope", centre=(0.5, -0.3), radius=0.3, **LAW)
    return sc


@pytest.mark.parametrize("kind", ["ground", "drum"])
def test_reach_switch_equals_all_pairs_bitwise(kind):
    asm = Assembly(_scene(kind))
    S = StepSystem(asm)
    xf, vf = ca.MX.sym("x", S.nf), ca.MX.sym("v", S.nf)
    all_pairs = ca.Function("all", [xf, vf], list(damping.contact_dissipation_mx(S, S.x_full_mx(xf),
                                                                               ca.mtimes(dm(S.E), vf))))
    rng = np.random.default_rng(1)
    touched = 0
    # lowered by 0 (1 cm above the ground / drum top after the 5 mm radius) .. 8 cm (in contact), and the round-off
    # neighbourhood of touch-down (0.045 m: the centre line's surface at the surface)
    for dy in (0.0, -0.03, -0.0449999, -0.045, -0.0450001, -0.047, -0.06, -0.08):
        x = asm.x0.copy()
        x[1::4] += dy  # y of every node (cable2d node: x, y, r_x, r_y)
        v = rng.normal(size=S.nf)
        got, ref = S.damp_f(S.reduce(x), v), all_pairs(S.reduce(x), v)
        for g, r in zip(got, ref):
            assert g.sparsity() == r.sparsity() or float(ca.norm_inf(r)) == 0.0
            assert np.array_equal(np.asarray(ca.densify(g)), np.asarray(ca.densify(r)))
        touched += float(ca.norm_inf(ref[0])) > 0
    assert touched >= 3  # the comparison covers states in contact, not only zeros


def test_chunk_damping_forces_in_one_call_equal_per_state():
    """The time loop books the damping work of a chunk's steps from one mapped call: the same forces as one call
    per state (states out of reach and in contact, random velocities)."""
    from ancf_sym.system.damping import damping_force, damping_force_rows

    asm = Assembly(_scene("ground"))
    S = StepSystem(asm)
    rng = np.random.default_rng(2)
    Q = np.array([S.reduce(asm.x0 + np.tile([0.0, dy, 0.0, 0.0], asm.n // 4)) for dy in (0.0, -0.046, -0.05)])
    V = rng.normal(size=Q.shape)
    rows = damping_force_rows(S, Q, V)
    assert np.any(rows != 0.0)
    for j in range(len(Q)):
        assert np.array_equal(rows[j], damping_force(S, Q[j], V[j]))
