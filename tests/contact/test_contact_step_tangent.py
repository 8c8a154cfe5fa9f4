"""The step matrix's dissipation term df/dx + cc df/dv with contact damping and friction summed per element before
its scatter (damping.step_tangent_function) against the separate tangents of damp_f: the same sum in another order,
on the belt drive (friction and contact damping on two body-carried pulleys, strain-rate damping of the belt) with
the belt sliding on the drums."""
import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "examples"))
import belt_drive as BD  # noqa: E402

from ancf_sym.model.assembly import Assembly  # noqa: E402
from ancf_sym.system import damping  # noqa: E402
from ancf_sym.system.step_system import StepSystem  # noqa: E402

N_EL, R2 = 16, 0.15


def test_summed_tangent_equals_the_separate_ones():
    asm = Assembly(BD.scene(R2, 20.0, 20.0, N_EL))
    S = StepSystem.for_scene(asm, linsol="auto_lu")
    x = S.reduce(BD.start(asm, R2, N_EL))
    v = np.random.default_rng(1).normal(scale=1.0, size=S.nf)  # (m/s: sliding both ways, friction active)
    cc = 1.7e3  # (1/s: a step's velocity coefficient at dt = 1 ms)
    f, dfx, dfv = (np.asarray(o.full() if hasattr(o, "full") else o) for o in S.damp_f(x, v))
    fs, T = damping.step_tangent_function(S)(x, v, cc)
    ref = dfx + cc * dfv
    assert np.abs(ref).max() > 0 and np.abs(dfv).max() > 0  # (contact in reach: the terms are there)
    # the same force (summed in the same order) and the same tangent to round-off of the summands' size: the blocks
    # are summed per element first, then scattered (a few additions per entry in another order)
    assert np.array_equal(np.asarray(fs.full()).ravel(), f.ravel())
    scale = np.abs(dfx).max() + cc * np.abs(dfv).max()
    assert np.abs(np.asarray(T.full()) - ref).max() <= 64 * np.finfo(float).eps * scale
