"""Dynamics of a scene: M q'' + C q' + grad U(q) + J^T lam = Q(t), Phi(q) = 0, by implicit integration.

    res = run_dynamics(scene, {"integrator": "generalized_alpha", "dt": 1e-3, "t_end": 2.0, "rho_inf": 0.9,
                               "output_dt": 0.01,
                               "sensors": [{"name": "tip", "kind": "position", "member": "beam", "at": "end"}]})
    res.t, res.sensors["tip"], res.energies["kinetic"], res.status

Integrators: "newmark" (beta, gamma), "hht" (alpha in [-1/3, 0]), "generalized_alpha" (rho_inf); "radau" and
"gauss" (collocation, `stages`). Fixed step by default; `adaptive` controls the local error estimate against
`tol` [m]. A step whose Newton iteration fails is rejected and retried with half the step (recorded in
`rejected`); the run ends with status "newton_failed" at the last good state when the step would fall below
dt_min. Results never contain NaN.

Energy bookkeeping at every output time: kinetic 1/2 v.M v, potential by label (strain energies, gravity, dead
loads, penalty joints), damping_work (work done against the damping forces) and external_work (of time-dependent
loads), both as the work of the forces of the discrete equations along each step, dq.(f_n + f_n+1)/2 (exact in the
energy identity of trapezoidal Newmark), and `algorithmic` = E(0) + external_work - damping_work - (kinetic +
potential): the energy the integrator itself removed (positive) or added (negative).

The modules, in the order of the data flow:

- options, sensors, time_loads: what a run asks for (checked before any work);
- step_system (with forces, damping, ldl, graph_cache): the equations on the reduced coordinates
  (ancf_sym.model.reduced) as compiled CasADi Functions, one Newton iteration per call, cached by scene structure;
- newton: Newton's method on a step system (full, or modified in Python);
- schemes, alpha_step, alpha, chunks: the Newmark / HHT / generalized-alpha family, its compiled step graph and
  chunks of many steps per call; collocation: Radau IIA and Gauss-Legendre;
- integrator: the protocol the time loop drives, and the consistent initial acceleration;
- time_loop, recording, result, run: the loop, its outputs, the result, and `simulate` / `run_dynamics`.
"""
from ancf_sym.model.assembly import LINEAR_EFFECTS
from ancf_sym.dynamics.alpha import AlphaIntegrator
from ancf_sym.dynamics.collocation import CollocationIntegrator
from ancf_sym.system.damping import RayleighData, StrainRateData, rayleigh_data, strain_rate_data
from ancf_sym.system.graph_cache import clear_graph_cache
from ancf_sym.dynamics.integrator import ChunkedIntegrator, Integrator
from ancf_sym.dynamics.newton import Counters, NewtonOptions
from ancf_sym.dynamics.options import DynamicOptions, options_from_dict
from ancf_sym.dynamics.result import DynamicResult
from ancf_sym.dynamics.run import make_integrator, run_dynamics, simulate
from ancf_sym.dynamics.schemes import Scheme
from ancf_sym.dynamics.sensors import Sensor
from ancf_sym.system.step_system import StepSystem
from ancf_sym.dynamics.time_loads import TimeLoad

__all__ = ["LINEAR_EFFECTS", "AlphaIntegrator", "ChunkedIntegrator", "CollocationIntegrator", "Counters",
           "DynamicOptions", "DynamicResult", "Integrator", "NewtonOptions", "RayleighData", "Scheme", "Sensor",
           "StepSystem", "StrainRateData", "TimeLoad", "clear_graph_cache", "make_integrator", "options_from_dict",
           "rayleigh_data", "run_dynamics", "simulate", "strain_rate_data"]
