"""The update tolerance's leftover-force bound per kind of unknown (ancf_sym.dynamics.alpha_step.work_scale,
docs/hard_cases.md, Spinning bending-free cables): which unknowns are positions, and that the work per unit
error by kind is at most kmax x max |dq| over all unknowns (the tolerance never tighter than before) and at least
either kind's own product."""
from __future__ import annotations

import casadi as ca
import numpy as np

from ancf_sym import Material, Scene, Section
from ancf_sym.model.assembly import Assembly
from ancf_sym.system.step_system import StepSystem
from ancf_sym.dynamics.alpha_step import work_scale


def test_position_unknowns_are_node_positions_and_body_centres():
    """A planar cable of 4 elements (5 nodes: x, y, x', y') hanging from a free planar body (x, y and its unit
    axis (c, s)): every node's x, y and the body's centre are positions [m], the gradients and the axis not."""
    s = Scene(dim=2, gravity=(0, -9.81))
    s.member("c", [(0, 0), (1, 0)], 4, Material(E=1e9, density=1000), Section.circle(0.005))
    s.body("b", 1.0, 0.01, (0.0, 0.0))
    s.pin_body("b", "c", "start")
    S = StepSystem(Assembly(s))
    full = S.full_v(S.is_position.astype(float))  # (each scene coordinate: its unknown's kind)
    asm = S.asm
    mm = asm.mesh.members["c"]
    k = np.arange(mm.x0.size)
    assert np.all(full[mm.offset + k[k % mm.node_size < 2]] == 1.0)
    assert np.all(full[mm.offset + k[k % mm.node_size >= 2]] == 0.0)
    o = asm.mesh.bodies["b"]
    assert list(full[o:o + 4]) == [1.0, 1.0, 0.0, 0.0]


def test_work_scale_by_kind_between_each_product_and_the_overall_bound():
    """For any stiffness and motion per kind: the larger of the two products, so at most kmax x max |dq| (the bound
    over all unknowns, never tighter than before) and at least each kind's own product (a kind's stiffness always
    meets its own motion)."""
    k, d = ca.SX.sym("k", 2), ca.SX.sym("d", 2)
    f = ca.Function("w", [k, d], [work_scale([k[0], k[1]], [d[0], d[1]])])
    rng = np.random.default_rng(3)
    for _ in range(200):
        kv, dv = 10.0 ** rng.uniform(-3, 9, 2), 10.0 ** rng.uniform(-6, 0, 2)
        w = float(f(kv, dv))
        assert w <= kv.max() * dv.max() * (1 + 1e-15)
        assert w >= max(kv[0] * dv[0], kv[1] * dv[1]) * (1 - 1e-15)
