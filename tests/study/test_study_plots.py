"""error_vs_time.png encodes one axis per visual channel, so a reader takes a study in at a glance: colour = the
method axis (integrator, strain, method, element: categorical), marker = the refinement axis, then marker size and
fill; every axis of every registered study is shown exactly once (an axis shown twice or not at all would make the
legends lie)."""
from __future__ import annotations

import pytest

from ancf_sym.study import get_study, studies
from ancf_sym.study.report import encodings


@pytest.mark.parametrize("name", sorted(studies()))
def test_every_axis_has_exactly_one_channel(name):
    st = get_study(name)
    enc = encodings(st)
    shown = [enc[c] for c in ("colour", "marker", "size", "fill") if c in enc] + list(enc["colour_extra"])
    assert sorted(shown) == sorted(a.name for a in st.axes)
    assert st.axis(enc["colour"]).kind is str, "colour shows a categorical axis"
    if st.refine_axis:
        assert enc["marker"] == st.refine_axis


def test_rope_reads_integrator_by_colour_n_by_marker_dt_by_size():
    assert encodings(get_study("rope")) == {"colour": "integrator", "marker": "n", "size": "dt", "colour_extra": []}
