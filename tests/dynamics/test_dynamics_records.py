"""The outputs of a compiled chunk are recorded together (Recorder.record_many: one gather of the scene
coordinates, one call of the energy graph mapped over the records, one product for the constraint rows): the
records hold the values that recording them one by one gives."""
from __future__ import annotations

import numpy as np
from ancf_sym import Material, Scene, Section
from ancf_sym.model.assembly import Assembly
from ancf_sym.dynamics import DynamicOptions, StepSystem, simulate
from ancf_sym.dynamics import time_loop
from ancf_sym.dynamics.recording import Recorder
from ancf_sym.dynamics.sensors import Sensor, SensorEval

SENSORS = [dict(name=f"{k}_{m}", kind=k, member=m, at=at) for k, m, at in (
    ("position", "b", "end"), ("displacement", "a", 0.2), ("velocity", "b", 0.1), ("strain", "a", 0.3),
    ("curvature", "b", 0.25), ("coordinates", "a", 2))]


def frame() -> Scene:
    """Two cables, the first pinned, joined rigidly: support rows on fixed coordinates only (their violation is
    the same at every record) and joint rows on unknowns."""
    s = Scene(dim=2, gravity=(0.0, -9.81))
    mat, sec = Material(E=2e7, density=1000.0), Section(area=1e-4, I=1e-10)
    s.member("a", [(0.0, 0.0), (0.5, 0.0)], 3, mat, sec, axial="biot")
    s.member("b", [(0.5, 0.0), (0.9, 0.3)], 3, mat, sec, axial="biot")
    s.pin("a", "start")
    s.rigid(("a", "end"), ("b", "start"))
    return s


def _recorder(S: StepSystem) -> Recorder:
    sensors = [SensorEval(Sensor.from_dict(d, i), S.asm, i) for i, d in enumerate(SENSORS)]
    rec = Recorder(S, sensors)
    rec.E0 = 1.0
    return rec


def test_records_together_equal_records_one_by_one():
    """Sensors and energies bit for bit (the same sensor code on the same coordinates; each record's energies by
    the same compiled graph, mapped); the constraint violation to round-off: the rows' products for all records
    are one matrix product, which BLAS may sum in another order than a product per record, so they agree to a
    few ulps of sum |A_ij x_j| (a relative 1e-12 of that scale is ~4000 ulps). The violation itself is the
    constraints' max |Phi(x)| over all rows, supports on fixed coordinates included."""
    asm = Assembly(frame())
    S = StepSystem.for_scene(asm)
    rng = np.random.default_rng(7)
    Q = S.reduce(asm.x0) + 1e-3 * rng.standard_normal((4, S.nf))
    V = rng.standard_normal((4, S.nf))
    ts = [0.1, 0.2, 0.3, 0.4]
    one, many = _recorder(S), _recorder(S)
    for t, q, v in zip(ts, Q, V):
        one.record(t, q, v, 0.5, 2.0)
    many.record_many(ts, Q, V, 0.5, 2.0)
    assert one.t == many.t == ts
    for d in SENSORS:
        assert np.array_equal(np.array(one.data[d["name"]]), np.array(many.data[d["name"]]))
    assert one.energies == many.energies and one.energies["kinetic"][0] > 0
    cons = asm.constraints
    X = S.full_rows(Q)
    scale = np.abs(cons.A.toarray()) @ np.abs(X.T).max(axis=1) + np.abs(cons.d)
    exact = [float(np.abs(cons.value(x)).max()) for x in X]
    assert min(exact) > 1e-8  # (the joint rows are violated: the check below is not 0 == 0)
    np.testing.assert_allclose(one.viol, exact, rtol=0, atol=1e-12 * scale.max())
    np.testing.assert_allclose(many.viol, exact, rtol=0, atol=1e-12 * scale.max())


def test_a_chunked_run_records_what_recording_one_by_one_records(monkeypatch):
    """A run in compiled chunks with outputs on and between the steps (interpolated), its records made together
    and, in the same run again, one by one: the same records, the rest bit for bit, the violation to round-off
    (coordinates and row coefficients of order 1: a few ulps of 1 m, 1e-14 m)."""
    opts = DynamicOptions(dt=1e-3, t_end=0.1, integrator="generalized_alpha", rho_inf=0.9, output_dt=0.0025,
                          sensors=SENSORS)
    together = simulate(Assembly(frame()), opts)

    def one_by_one(self, ts, Q, V, damping_work, external_work):
        for t, q, v in zip(ts, Q, V):
            self.record(t, q, v, damping_work, external_work)

    monkeypatch.setattr(Recorder, "record_many", one_by_one)
    alone = simulate(Assembly(frame()), opts)
    assert together.status == alone.status == "completed" and len(together.t) == 41
    assert np.array_equal(together.x, alone.x) and np.array_equal(together.t, alone.t)
    for k in together.sensors:
        assert np.array_equal(together.sensors[k], alone.sensors[k]), k
    for k in together.energies:
        assert np.array_equal(together.energies[k], alone.energies[k]), k
    assert together.constraint_violation.max() > 1e-12
    np.testing.assert_allclose(together.constraint_violation, alone.constraint_violation, rtol=0, atol=1e-14)
