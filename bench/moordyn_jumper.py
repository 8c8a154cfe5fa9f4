"""MoorDyn's run of the Lowe & Langley jumper, shared by the benches that set this package beside it
(bench/mooring_vs_moordyn.py: the top end moved in surge; bench/waves_vs_moordyn.py: a fixed top in waves).

MOORDYN_INPUT is MoorDyn's test input for the jumper (the line data both benches use). `top_tension` runs it,
coupled every 5 ms (MoorDyn steps its own dtM = 1 ms inside), and returns |F_top| at the given output times and
the CPU time of the steps after MoorDyn's initial-condition solve. Needs `pip install moordyn` (the bench extra).
"""
from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path
from typing import Callable

import numpy as np

MOORDYN_INPUT = """MoorDyn input file: the Lowe and Langley (2006) flexible jumper
False  Echo
----------------------- LINE TYPES ------------------------------------------
TypeName   Diam     Mass/m     EA         BA/-zeta    EI         Cd     Ca     CdAx    CaAx
(name)     (m)      (kg/m)     (N)        (N-s/-)     (N-m^2)    (-)    (-)    (-)     (-)
main       0.396    165.0      500.0e6    -0.5        120.8e3    1.0    1.0    0.0     0.0
---------------------- POINTS --------------------------------
ID    Type      X       Y       Z       Mass    Volume      CdA    Ca
(#)   (-)       (m)     (m)     (m)     (kg)    (m^3)       (m^2)  (-)
1     Fixed     -100    0       -55     0       0           0      0
2     Coupled   0       0       -5      0       0           0      0
---------------------- LINES ----------------------------------------
ID   LineType   AttachA  AttachB  UnstrLen  NumSegs  LineOutputs
(#)   (name)     (#)      (#)       (m)       (-)     (-)
1      main      1        2         170       68      -
---------------------- OPTIONS -----------------------------------------
0             writeLog
0.001         dtM
3.0e6         kBot
3.0e5         cBot
100           WtrDpth
1000.0        WtrDnsty
9.807         g
midpoint5     tScheme
5.0           CdScaleIC
30            TmaxIC
1.0           dtIC
5e-3          threshIC
0             ICgenDynamic
1             disableOutTime
------------------------- need this line --------------------------------------
"""

COUPLING_DT = 0.005  # [s] between two coupled steps (MoorDyn's test)


def top_tension(times: np.ndarray, surge: Callable[[float], float] | None = None,
                waves: Callable[[np.ndarray, float], tuple[np.ndarray, np.ndarray]] | None = None) -> dict:
    """|F_top| of MoorDyn's jumper at `times`, and the CPU time of its steps.

    surge(t): the top point's x displacement from its initial position at time t (None: the top held).
    waves(p, t): water velocity and acceleration (n x 3 each) at MoorDyn's node coordinates p (n x 3) at time t,
    passed by MoorDyn's external wave kinematics (None: still water)."""
    import moordyn as md

    text = MOORDYN_INPUT if waves is None else \
        MOORDYN_INPUT.replace("0.001         dtM", "0.001         dtM\n1             WaveKin")
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "jumper.txt")
        Path(path).write_text(text)
        system = md.Create(path)
        point = md.GetPoint(system, 2)
        r0 = list(md.GetPointPos(point))
        md.Init(system, r0, [0.0, 0.0, 0.0])
        if waves is not None:
            md.ExternalWaveKinInit(system)
        dt, t, k = COUPLING_DT, 0.0, 0
        out = np.full(len(times), np.nan)
        c0 = time.process_time()
        while k < len(times):
            if waves is not None:
                p = np.array(md.ExternalWaveKinGetCoordinates(system))
                u, a = waves(p, t + 0.5 * dt)
                md.ExternalWaveKinSet(system, np.asarray(u).tolist(), np.asarray(a).tolist(), t)
            if surge is None:
                r, u_top = r0, [0.0, 0.0, 0.0]
            else:  # (the coupled point's velocity brings it to the prescribed position at the step's end)
                r = list(md.GetPointPos(point))
                u_top = [(r0[0] + surge(t + dt) - r[0]) / dt, 0.0, 0.0]
            md.Step(system, r, u_top, t, dt)
            t += dt
            while k < len(times) and times[k] <= t + 1e-9:
                out[k] = float(np.linalg.norm(md.GetPointForce(point)))
                k += 1
        cpu = time.process_time() - c0
        md.Close(system)
    return dict(tension=out, cpu_s=cpu)
