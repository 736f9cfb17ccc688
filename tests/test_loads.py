"""State-dependent loads: expression torques and forces, pd_control, gravity_gradient.

Every bound is stated where it is asserted.  References: existing load kinds (same physics
written another way), closed forms (detumbling, gravity-gradient pitch libration), mpmath's
high-precision derivatives (Taylor-mode series of every function)."""

from __future__ import annotations

import math
import subprocess
import sys
import types
from pathlib import Path

import mpmath
import numpy as np
import pytest

import rotlab
from rotlab.config import parse_scenario
from rotlab.config.expressions import FormulaError, parse_formula
from rotlab.core import opcodes, quaternion as quat
from rotlab.core.dynamics import rhs
from rotlab.core.expressions import series_step
from rotlab.errors import InputError
from rotlab.scene.programs import ProgramBuilder
from rotlab.scene.scene import build_scene

STEPPERS = ("rk4", "rkmk4", "dop853", "taylor")
ROTLAB = Path(sys.executable).with_name("rotlab")
TILTED = [[2.0, 0.3, -0.1], [0.3, 3.0, 0.2], [-0.1, 0.2, 4.0]]  # not principal: exercises the user frame


def _generated(address: int, consts: np.ndarray):
    """The scene's generated formulas at ``address`` (``rotlab.scene.formulas``) as a Python
    function of (load, component, *inputs), reading the constants ``consts``."""
    import ctypes

    signature = ctypes.CFUNCTYPE(ctypes.c_double, ctypes.c_int64, ctypes.c_int64, ctypes.POINTER(ctypes.c_double),
                                 ctypes.POINTER(ctypes.c_double), *[ctypes.c_double] * opcodes.N_INPUTS)
    function, held = signature(address), np.ascontiguousarray(consts, dtype=float)
    pointer = held.ctypes.data_as(ctypes.POINTER(ctypes.c_double))
    return lambda load, component, *x: function(load, component, pointer, None, *x)


def _scenario(loads, method, body=None, end=2.0, omega=(0.3, -1.1, 0.7), **solver):
    body = body or {"inertia_tensor": TILTED, "mass": 2.0, "center_of_mass": [0.1, -0.05, 0.3]}
    settings = {"method": method, "rtol": 1e-12, "atol": 1e-14, **solver}
    if method in ("rk4", "rkmk4"):
        settings = {"method": method, "step": 1e-3}
    return parse_scenario({"body": body, "initial": {"omega": list(omega), "axis_angle": [0.2, -0.4, 0.1]},
                           "loads": loads, "time": {"end": end, "samples": 41}, "solver": settings})


def _states(loads, method, **kw):
    traj = rotlab.simulate(_scenario(loads, method, **kw))
    assert traj.stats.failure is None
    return np.column_stack([traj.quaternion, traj.omega])


PAIRS = {
    "damping": ([{"type": "damping", "coefficient": 0.4}],
                [{"type": "expression", "frame": "body", "constants": {"k": 0.4},
                  "torque": ["-k*omega[0]", "-k*omega[1]", "-k*omega[2]"]}]),
    "torque body": ([{"type": "torque", "frame": "body", "value": [0.3, -0.2, 0.5]}],
                    [{"type": "expression", "frame": "body", "torque": ["0.3", "-0.2", "0.5"]}]),
    "torque space": ([{"type": "torque", "frame": "space", "value": [0.3, -0.2, 0.5], "window": {"on": 0.5, "off": 1.5}}],
                     [{"type": "expression", "frame": "space", "torque": ["0.3", "-0.2", "0.5"], "window": {"on": 0.5, "off": 1.5}}]),
    "harmonic": ([{"type": "harmonic_torque", "frame": "space", "amplitude": [0.4, 0.1, -0.3], "angular_frequency": 3.0, "phase": 0.5}],
                 [{"type": "expression", "frame": "space", "constants": {"w": 3.0, "phi": 0.5},
                   "torque": ["0.4*sin(w*t + phi)", "0.1*sin(w*t + phi)", "-0.3*sin(w*t + phi)"]}]),
    "gravity as gamma": ([{"type": "gravity", "g": [0.0, 0.0, -9.81]}],
                         [{"type": "expression", "frame": "body", "up": [0.0, 0.0, 2.0],
                           "constants": {"mg": 2.0 * 9.81, "cx": 0.1, "cy": -0.05, "cz": 0.3},
                           "torque": ["-mg*(cy*gamma[2] - cz*gamma[1])", "-mg*(cz*gamma[0] - cx*gamma[2])",
                                      "-mg*(cx*gamma[1] - cy*gamma[0])"]}]),
    "space force at a point": ([{"type": "force", "frame": "space", "value": [1.0, -2.0, 0.5], "point": [0.2, 0.1, -0.3]}],
                               [{"type": "expression", "frame": "space", "force": ["1", "-2", "0.5"], "point": [0.2, 0.1, -0.3]}]),
}


@pytest.mark.parametrize("method", STEPPERS)
@pytest.mark.parametrize("pair", list(PAIRS))
def test_expression_equals_the_built_in_kind(pair, method):
    """An expression written as an existing load kind gives the same motion to 1e-12 (Λ and ω,
    every sample; a non-principal body, so the user-frame inputs and outputs are exercised).
    Adaptive methods at rtol 1e-13: rounding-level differences of the torque move their step
    sequence, so two runs agree only to the tolerance."""
    builtin, expression = PAIRS[pair]
    a, b = _states(builtin, method, rtol=1e-13, atol=1e-15), _states(expression, method, rtol=1e-13, atol=1e-15)
    assert np.max(np.abs(a - b)) < 1e-12


def test_expression_inputs_q_and_L_in_the_users_frame():
    """q is Λ in the user's body frame and L = I ω there: −k L / I_diag on a principal body
    equals damping, and a torque built from q matches rotating a space vector by hand (rhs to 1e-14)."""
    body = {"principal_moments": [2.0, 3.0, 4.0]}
    via_L = [{"type": "expression", "frame": "body", "constants": {"k": 0.4},
              "torque": ["-k*L[0]/2", "-k*L[1]/3", "-k*L[2]/4"]}]
    assert np.max(np.abs(_states(via_L, "dop853", body=body) - _states(PAIRS["damping"][0], "dop853", body=body))) < 1e-12
    # Rᵀ e_z from q: the third row of R, (2(q1q3 − q0q2), 2(q2q3 + q0q1), q0² − q1² − q2² + q3²)
    from_q = [{"type": "expression", "frame": "body", "torque": ["2*(q[1]*q[3] - q[0]*q[2])", "2*(q[2]*q[3] + q[0]*q[1])",
                                                                    "q[0]**2 - q[1]**2 - q[2]**2 + q[3]**2"]}]
    from_gamma = [{"type": "expression", "frame": "body", "torque": ["gamma[0]", "gamma[1]", "gamma[2]"]}]
    for loads_a, loads_b in ((from_q, from_gamma),):
        sa, sb = build_scene(_scenario(loads_a, "dop853")), build_scene(_scenario(loads_b, "dop853"))
        y = np.array([*sa.q0, 0.3, 0.2, -0.1, 0.0])
        da, db = np.zeros(8), np.zeros(8)
        rhs(0.3, y, da, sa.model)
        rhs(0.3, y, db, sb.model)
        np.testing.assert_allclose(da, db, rtol=0, atol=1e-14)


@pytest.mark.parametrize("method", STEPPERS)
def test_energy_balance_with_expression_loads(method):
    """T + V − W stays constant (relative drift < 1e-9 for dop853/taylor at rtol 1e-12, < 1e-7 for
    the fixed-step methods at h = 1e-3) with gravity, an expression torque and an expression force."""
    loads = [{"type": "gravity"},
             {"type": "expression", "frame": "body", "constants": {"k": 0.2}, "torque": ["-k*omega[0]*abs(omega[1])", "sin(t)*gamma[2]", "0.1*q[1]"]},
             {"type": "expression", "frame": "space", "force": ["0.5*cos(2*t)", "0", "-0.3"], "point": [0.0, 0.2, 0.1]}]
    traj = rotlab.simulate(_scenario(loads, method))
    bound = 1e-9 if method in ("dop853", "taylor") else 1e-7
    assert traj.work is not None and float(np.max(np.abs(traj.work))) > 1e-2  # the loads do work
    assert traj.max_drift()["energy"] < bound


@pytest.mark.parametrize("method", STEPPERS)
def test_detumbling_matches_the_closed_form(method):
    """M = −K ω on an axisymmetric body (A, A, C): C ṙ = −K r and A (ṗ + i q̇) = −i (A − C) r (p + i q) − K (p + i q), so
    |ω|² = (p₀² + q₀²) e^{−2Kt/A} + r₀² e^{−2Kt/C}.  Relative error < 1e-10 (dop853, taylor) / 1e-9 (h = 1e-3)."""
    a, c, k = 2.0, 3.0, 0.7
    omega0 = np.array([1.5, -0.5, 4.0])
    scenario = parse_scenario({
        "body": {"principal_moments": [a, a, c]}, "initial": {"omega": omega0.tolist()},
        "loads": [{"type": "expression", "frame": "body", "constants": {"K": k}, "torque": ["-K*omega[0]", "-K*omega[1]", "-K*omega[2]"]}],
        "time": {"end": 5.0, "samples": 51},
        "solver": {"method": method, **({"step": 1e-3} if method in ("rk4", "rkmk4") else {"rtol": 1e-12, "atol": 1e-15})}})
    traj = rotlab.simulate(scenario)
    t = traj.t
    expected = np.sqrt((omega0[0] ** 2 + omega0[1] ** 2) * np.exp(-2 * k * t / a) + omega0[2] ** 2 * np.exp(-2 * k * t / c))
    error = np.abs(np.linalg.norm(traj.omega, axis=1) - expected) / expected
    assert float(np.max(error)) < (1e-10 if method in ("dop853", "taylor") else 1e-9)


def _pitch(traj, n):
    """Pitch θ: the angle of body x from the local vertical (cos nt, sin nt, 0), about the orbit normal z."""
    x_space = quat.rotate_to_space_array(traj.quaternion / np.linalg.norm(traj.quaternion, axis=1, keepdims=True),
                                         np.broadcast_to([1.0, 0.0, 0.0], (len(traj.t), 3)))
    return np.unwrap(np.arctan2(x_space[:, 1], x_space[:, 0]) - n * traj.t)


@pytest.mark.parametrize("method", ["dop853", "taylor"])
def test_gravity_gradient_pitch_libration(method):
    """Earth-pointing body, x along the local vertical, z along the orbit normal (rate n), pitch θ
    about z.  γ = (cos θ, −sin θ, 0) in the body, so M_z = 3n² (γ × Iγ)_z = −3n² (B − A) sin θ cos θ and
    C θ̈ = −3n² (B − A) θ for small θ: librations at ω_p = n √(3 (B − A)/C).
    Measured period within 1e-4 relative (amplitude 1e-3 rad: the nonlinear shift is ~θ₀²/16)."""
    n, a, b, c, theta0 = 0.05, 1.0, 2.0, 2.5, 1e-3
    expected = 2 * math.pi / (n * math.sqrt(3 * (b - a) / c))
    scenario = parse_scenario({
        "body": {"principal_moments": [a, b, c]},
        "initial": {"omega": [0.0, 0.0, n], "axis_angle": [0.0, 0.0, theta0]},
        "loads": [{"type": "gravity_gradient", "orbit_rate": n, "vertical": [1, 0, 0], "orbit_normal": [0, 0, 1]}],
        "time": {"end": 3.2 * expected, "samples": 20001}, "solver": {"method": method, "rtol": 1e-12, "atol": 1e-15}})
    traj = rotlab.simulate(scenario)
    theta = _pitch(traj, n)
    assert abs(theta[0] - theta0) < 1e-15 and float(np.max(np.abs(theta))) < 1.01 * theta0
    down = np.nonzero((theta[:-1] > 0) & (theta[1:] <= 0))[0]  # downward zero crossings, linearly interpolated
    crossings = traj.t[down] + theta[down] / (theta[down] - theta[down + 1]) * (traj.t[down + 1] - traj.t[down])
    period = float(np.mean(np.diff(crossings)))
    assert len(crossings) >= 3 and abs(period / expected - 1.0) < 1e-4


@pytest.mark.parametrize("saturation", [None, 0.05])
def test_pd_control_reaches_its_target(saturation):
    """From a tumble, the PD law drives δ = Λ_target⁻¹ ∘ Λ to the identity and ω to 0:
    |δ_v| < 1e-6 and |ω| < 1e-6 rad/s after 60 s (kp = 1, kd = 2 on moments 1–3 kg·m²);
    with saturation every torque component stays within ±0.05 N·m (checked on the samples)."""
    target = quat.from_axis_angle(np.array([1.0, 2.0, -1.0]), 2.0)
    load = {"type": "pd_control", "target": target.tolist(), "kp": 1.0, "kd": 2.0}
    if saturation:
        load["max_torque"] = saturation
    end = 60.0 if saturation is None else 400.0
    scenario = parse_scenario({"body": {"principal_moments": [1.0, 2.0, 3.0]}, "initial": {"omega": [0.4, -0.3, 0.2]},
                               "loads": [load], "time": {"end": end, "samples": 2001}, "solver": {"method": "dop853"}})
    traj = rotlab.simulate(scenario)
    delta = quat.multiply_array(quat.conjugate_array(target), traj.quaternion[-1])
    assert np.linalg.norm(delta[1:]) < 1e-6 and np.linalg.norm(traj.omega[-1]) < 1e-6
    if saturation:  # M = I ω̇ + ω × I ω from the right-hand side at every sample (principal body)
        scene = traj.scene
        dy = np.zeros(8)
        worst = 0.0
        for q, w in zip(traj.quaternion, traj.omega):
            rhs(0.0, np.array([*q, *w, 0.0]), dy, scene.model)
            worst = max(worst, float(np.max(np.abs(scene.moments * dy[4:7] + np.cross(w, scene.moments * w)))))
        assert worst <= saturation * (1 + 1e-12)


@pytest.mark.parametrize("kind", ["pd_control", "gravity_gradient"])
def test_every_stepper_supports_the_built_in_state_loads(kind):
    """rk4, rkmk4 (h = 1e-3) and taylor agree with dop853 (rtol 1e-12) to 1e-8 on Λ and ω."""
    load = ({"type": "pd_control", "target": [0.0, 1.0, 0.0, 0.0], "kp": 2.0, "kd": 1.0, "max_torque": 1.0} if kind == "pd_control"
            else {"type": "gravity_gradient", "orbit_rate": 1.0, "vertical": [0, 1, 0], "orbit_normal": [1, 0, 0]})
    reference = _states([load], "dop853")
    for method in ("rk4", "rkmk4", "taylor"):
        assert np.max(np.abs(_states([load], method) - reference)) < 1e-8, method


# ---- Taylor mode ----------------------------------------------------------------------------------

FUNCTIONS = {  # formula of t, and the same function for mpmath
    "sin": ("sin(0.3 + 0.7*t - 0.2*t**2)", lambda t: mpmath.sin(0.3 + 0.7 * t - 0.2 * t**2)),
    "cos": ("cos(0.3 + 0.7*t - 0.2*t**2)", lambda t: mpmath.cos(0.3 + 0.7 * t - 0.2 * t**2)),
    "tan": ("tan(0.3 + 0.7*t)", lambda t: mpmath.tan(0.3 + 0.7 * t)),
    "tanh": ("tanh(0.3 - 0.9*t)", lambda t: mpmath.tanh(0.3 - 0.9 * t)),
    "exp": ("exp(0.5*t - t**2)", lambda t: mpmath.exp(0.5 * t - t**2)),
    "log": ("log(2 + t + 0.5*t**2)", lambda t: mpmath.log(2 + t + 0.5 * t**2)),
    "sqrt": ("sqrt(1.5 + t - 0.3*t**3)", lambda t: mpmath.sqrt(1.5 + t - 0.3 * t**3)),
    "division": ("(1 + 2*t)/(3 - t + t**2)", lambda t: (1 + 2 * t) / (3 - t + t**2)),
    "real power": ("(2 + t)**2.5", lambda t: (2 + t) ** mpmath.mpf(2.5)),
    "negative power": ("(2 + t)**-3", lambda t: (2 + t) ** -3),
    "integer power": ("(0.5*t - 0.1)**5", lambda t: (0.5 * t - 0.1) ** 5),
    "atan2": ("atan2(1 + 0.5*t, 2 - t)", lambda t: mpmath.atan2(1 + 0.5 * t, 2 - t)),
    "abs": ("abs(0.2 - 3*t)", lambda t: abs(0.2 - 3 * t)),
    "min max sign": ("min(t, 1 - t) + max(sin(t), 0.3) + sign(t - 2)", lambda t: min(t, 1 - t) + max(mpmath.sin(t), 0.3) + mpmath.sign(t - 2)),
    "composite": ("exp(sin(t))*sqrt(1 + t**2) - log(cos(t) + 2)/(1 + t)",
                  lambda t: mpmath.exp(mpmath.sin(t)) * mpmath.sqrt(1 + t**2) - mpmath.log(mpmath.cos(t) + 2) / (1 + t)),
}


@pytest.mark.parametrize("name", list(FUNCTIONS))
def test_taylor_mode_series_match_mpmath(name):
    """Coefficients 0..20 of f(t0 + τ) from the Taylor-mode interpreter equal mpmath's (50 digits)
    to 1e-13 relative to max(1, |coefficient|) · r^−k scale (r the radius used: coefficients of
    these functions grow at most like 1.5^k here), and coefficient 0 equals the float interpreter."""
    text, reference = FUNCTIONS[name]
    order, t0 = 20, 0.25
    builder = ProgramBuilder()
    builder.formulas([text, "0", "0"], {}, 0.0, (-np.inf, np.inf))
    ex = builder.build(np.eye(3), np.ones(3))
    tape = np.zeros((ex.code.shape[0] + ex.aux, order + 1))
    stack = np.zeros(ex.depth, dtype=np.int64)
    inputs = np.zeros(opcodes.N_INPUTS)
    start, stop = int(ex.rows[0, 14]), int(ex.rows[0, 15])
    got = np.zeros(order + 1)
    for k in range(order + 1):
        inputs[0] = t0 if k == 0 else (1.0 if k == 1 else 0.0)
        got[k] = tape[series_step(ex.code, ex.consts, start, stop, k, inputs, tape, stack), k]
    mpmath.mp.dps = 50
    expected = [float(c) for c in mpmath.taylor(reference, mpmath.mpf(t0), order)]
    for k in range(order + 1):
        assert abs(got[k] - expected[k]) <= 1e-13 * max(1.0, abs(expected[k])) * 1.5**k, (k, got[k], expected[k])
    from rotlab.scene import formulas

    value = _generated(formulas.compiled(builder.programs).address, np.array(builder.slots.values))(0, 0, t0, *np.zeros(opcodes.N_INPUTS - 1))
    assert value == pytest.approx(float(reference(mpmath.mpf(t0))), rel=1e-14)


def _switched_torque_exact(t: np.ndarray, omega0, big_omega: float, m_before: float, m_after: float, t_switch: float) -> np.ndarray:
    """ω of an axisymmetric body (A = B) under a body-frame torque A·m about x that jumps from
    m_before to m_after at t_switch: r is constant and u = p + i (q − m/Ω) turns as e^{iΩt},
    Ω = (C − A) r / A (ṗ = −Ω q + m, q̇ = Ω p), p and q continuous at the switch."""
    p0, q0, r0 = omega0
    u_switch = (p0 + 1j * (q0 - m_before / big_omega)) * np.exp(1j * big_omega * t_switch)
    p_s, q_s = u_switch.real, u_switch.imag + m_before / big_omega
    before = (p0 + 1j * (q0 - m_before / big_omega)) * np.exp(1j * big_omega * t)
    after = (p_s + 1j * (q_s - m_after / big_omega)) * np.exp(1j * big_omega * (t - t_switch))
    p = np.where(t <= t_switch, before.real, after.real)
    q = np.where(t <= t_switch, before.imag + m_before / big_omega, after.imag + m_after / big_omega)
    return np.column_stack([p, q, np.full_like(t, r0)])


@pytest.mark.parametrize("text, before, after", [("0.01*sign(t - 1.3)", -1.0, 1.0), ("0.01*sign(1.3 - t)", 1.0, -1.0),
                                                  ("0.01*sign(t)", 1.0, 1.0), ("0.01*sign(-t)", -1.0, -1.0)])
def test_taylor_takes_a_signs_new_branch_on_the_step_after_its_switch(text, before, after):
    """The step that starts at a switch of sign(u) has u⁽⁰⁾ = 0 or, truncated, on the old side:
    it must take the branch the switch leads to (``switch_limit`` forces it), as abs, min and max
    do.  sign took sign(u⁽⁰⁾), so that step ran with the old torque or none: ω off by 3e-2 of its
    size at every tolerance.  Bound: 10·rtol of max |ω| against the closed form."""
    moments, omega0, rtol = (0.01, 0.01, 0.02), (0.3, -0.2, 5.0), 1e-10
    for method in ("taylor", "auto"):
        sc = parse_scenario({"body": {"principal_moments": list(moments)}, "initial": {"omega": list(omega0)},
                             "loads": [{"type": "expression", "frame": "body", "torque": [text, "0", "0"]}],
                             "time": {"end": 5.0, "sample_rate": 100}, "solver": {"method": method, "rtol": rtol}})
        traj = rotlab.simulate(sc)
        assert traj.stats.method == "taylor", traj.stats.reason
        t = np.linspace(0.0, 5.0, 501)
        exact = _switched_torque_exact(t, omega0, (moments[2] - moments[0]) * omega0[2] / moments[0], before, after, 1.3)
        error = float(np.max(np.abs(traj.omega - exact)))
        assert error < 10 * rtol * float(np.max(np.abs(exact))), (method, error)


@pytest.mark.parametrize("text", ["-0.01*sign(omega[0])", "0.01*abs(omega[1])", "0.01*min(omega[0], 0)"])
def test_taylor_keeps_a_switching_function_that_stays_at_zero_at_zero(text):
    """A spin exactly about z keeps ω_x = ω_y = 0, so these torques are 0 for ever: sign(0) is 0
    (as the pointwise formula gives for the other methods), not a side picked at 0."""
    sc = parse_scenario({"body": {"principal_moments": [0.01, 0.01, 0.02]}, "initial": {"omega": [0.0, 0.0, 5.0]},
                         "loads": [{"type": "expression", "frame": "body", "torque": [text, "0", "0"]}],
                         "time": {"end": 3.0, "sample_rate": 10}, "solver": {"method": "taylor", "rtol": 1e-10}})
    traj = rotlab.simulate(sc)
    assert np.all(traj.omega[:, :2] == 0.0) and np.all(traj.omega[:, 2] == 5.0)


@pytest.mark.parametrize("target", [[0.0, 0.0, 0.0, 1.0], [0.0, 0.0, 0.6, 0.8]])
def test_taylor_runs_two_switches_that_sit_at_the_start_together(target):
    """Saturated pd_control from Λ = 1 with τ₀ = 0 and kd ω_x = max_torque: sgn δ₀ and the
    saturation of M_x both switch exactly at t = 0.  Forcing one side dropped the other's forced
    side at the next formation, which forced it again, for ever: taylor (and auto) stopped at
    t = 0 ("step size fell below the resolution").  Bound: within 1e-10 of dop853 at rtol 1e-13."""
    base = {"body": {"principal_moments": [2.0, 3.0, 4.0]}, "initial": {"omega": [0.5, -1.0, 0.8]},
            "loads": [{"type": "pd_control", "target": target, "kp": 1.0, "kd": 1.0, "max_torque": 0.5}],
            "time": {"end": 20.0, "samples": 201}}
    runs = {}
    for method, rtol in (("taylor", 1e-12), ("auto", 1e-12), ("dop853", 1e-13)):
        traj = rotlab.simulate(parse_scenario({**base, "solver": {"method": method, "rtol": rtol, "atol": rtol * 1e-2}}))
        runs[method] = traj
    assert runs["auto"].stats.method == "taylor"
    for method in ("taylor", "auto"):
        assert float(np.max(np.abs(runs[method].omega - runs["dop853"].omega))) < 1e-10, method


def test_taylor_coefficients_of_an_expression_scene_are_the_rhs():
    """X[1] of the taylor kernel equals f(t, y) to 1e-14 with every input variable in use."""
    from rotlab.core import taylor
    from rotlab.methods.catalog.taylor import kernel_constants

    loads = [{"type": "expression", "frame": "space", "up": [0.3, 0.1, 1.0], "constants": {"c": 0.3},
              "torque": ["c*omega[1]*gamma[2] + q[0]*L[2]", "sin(t)*gamma[0] - L[1]", "atan2(q[2], q[3]) + t**2"]},
             {"type": "gravity_gradient", "orbit_rate": 0.8},
             {"type": "pd_control", "kp": 1.0, "kd": 0.5, "target": [0.0, 0.0, 1.0, 0.0], "max_torque": 10.0}]
    scene = build_scene(_scenario(loads, "taylor"))
    y = np.array([*scene.q0, 0.4, -0.2, 0.9, 0.0])
    X = taylor.coefficients(0.7, y, 12, scene.model, *kernel_constants(scene))
    dy = np.zeros(8)
    rhs(0.7, y, dy, scene.model)
    np.testing.assert_allclose(X[1], dy, rtol=1e-14, atol=1e-14)


# ---- bad and hostile formulas ---------------------------------------------------------------------

HOSTILE = {
    "__import__('os').system('echo hi')": "is not a function",
    "__import__('os')": "'__import__' is not a function",
    "omega.__class__": "Attribute is not allowed",
    "(lambda: 1)()": "is not a function",
    "[x for x in (1, 2)]": "ListComp is not allowed",
    "2**10**10": "exponent of ** must be",
    "omega[0]**1e6": "beyond ±64",
    "sin(" * 60 + "t" + ")" * 60: "nested too deeply",
    "-" * 100 + "1": "nested too deeply",
    "+".join(["t"] * 300): "more than 400 terms",
    "x" * 3000: "beyond the limit",
    "open('f')": "'open' is not a function",
    "t if t else 1": "IfExp is not allowed",
    "omega[7]": "omega[…] takes an index 0 … 2",
    "1 +": "syntax error",
    "q": "'q' is a vector",
}


@pytest.mark.parametrize("text", list(HOSTILE))
def test_hostile_formulas_are_refused(text):
    with pytest.raises(FormulaError, match=HOSTILE[text].replace("(", r"\(").replace("*", r"\*").replace("[", r"\[")):
        parse_formula(text, {})


def test_bad_formula_exits_2_naming_key_and_column(tmp_path):
    """Through the installed CLI: exit 2, one line naming loads[0].torque[1] and the column."""
    path = tmp_path / "bad.toml"
    path.write_text('[body]\nprincipal_moments = [1, 2, 3]\n[time]\nend = 1.0\n'
                    '[[loads]]\ntype = "expression"\nframe = "body"\ntorque = ["0", "-k*omega[0] + foo", "0"]\nconstants = { k = 1.0 }\n')
    result = subprocess.run([str(ROTLAB), "validate", str(path)], capture_output=True, text=True, timeout=120)
    assert result.returncode == 2
    assert "loads[0].torque[1]" in result.stderr + result.stdout and "column 15" in result.stderr + result.stdout
    assert "Traceback" not in result.stderr and "unknown name 'foo'" in result.stderr + result.stdout


def test_constants_may_not_shadow_variables():
    with pytest.raises(InputError, match=r"loads\[0\]\.constants\.omega"):
        parse_scenario({"body": {"principal_moments": [1, 2, 3]}, "time": {"end": 1.0},
                        "loads": [{"type": "expression", "frame": "body", "torque": ["0", "0", "0"], "constants": {"omega": 1.0}}]})


@pytest.mark.parametrize("method", STEPPERS)
def test_quadratic_drag_matches_the_closed_form(method):
    """Spherical body (I, I, I), M = −c|ω|ω: ω keeps its direction and I d|ω|/dt = −c|ω|², so
    |ω| = ω₀ / (1 + c ω₀ t / I).  Relative error < 1e-11 (dop853, taylor at rtol 1e-12; rk4 and
    rkmk4 at h = 1e-3); the direction of ω stays fixed to 1e-12."""
    inertia, c = 2.0, 0.5
    omega0 = np.array([1.0, -2.0, 0.5])
    solver = {"method": method, "rtol": 1e-12, "atol": 1e-15} if method in ("dop853", "taylor") else {"method": method, "step": 1e-3}
    traj = rotlab.simulate(parse_scenario({"body": {"principal_moments": [inertia] * 3}, "initial": {"omega": omega0.tolist()},
                                           "loads": [{"type": "quadratic_drag", "coefficient": c}],
                                           "time": {"end": 3.0, "samples": 31}, "solver": solver}))
    w0 = float(np.linalg.norm(omega0))
    expected = w0 / (1.0 + c * w0 * traj.t / inertia)
    norm = np.linalg.norm(traj.omega, axis=1)
    assert float(np.max(np.abs(norm - expected) / expected)) < 1e-11
    assert float(np.max(np.abs(traj.omega / norm[:, None] - omega0 / w0))) < 1e-12


def test_windowed_force_in_both_frames():
    """A force with a window acts only inside it: before `on` the motion is torque-free (ω
    unchanged on a spherical body), after `off` ω is constant again; body and space frames."""
    for frame in ("body", "space"):
        traj = rotlab.simulate(parse_scenario({
            "body": {"principal_moments": [1.0, 1.0, 1.0]}, "initial": {"omega": [0.0, 0.0, 0.5]},
            "loads": [{"type": "force", "frame": frame, "value": [0.0, 2.0, 0.0], "point": [0.0, 0.0, 0.5], "window": {"on": 1.0, "off": 2.0}}],
            "time": {"end": 3.0, "samples": 31}, "solver": {"method": "dop853"}}))
        before, after = traj.t < 1.0, traj.t >= 2.0
        assert np.max(np.abs(traj.omega[before] - [0.0, 0.0, 0.5])) < 1e-14
        assert np.max(np.abs(traj.omega[after] - traj.omega[-1])) < 1e-9
        assert np.linalg.norm(traj.omega[-1] - [0.0, 0.0, 0.5]) > 0.5  # about 1 N·m for 1 s on I = 1


# ---- Python callables -----------------------------------------------------------------------------


def _python_torque(t, q, omega):
    """A user's function: damping plus a harmonic term (plain Python; rotlab jits it)."""
    s = 0.3 * math.sin(2.0 * t)
    return -0.4 * omega[0] + s, -0.4 * omega[1] - s, -0.4 * omega[2] + 0.5 * s * q[0]


def test_python_torque_function_equals_the_same_expression():
    """rotlab.simulate(scenario, torque=fn, frame=...) with fn(t, q, omega) compiled by numba gives
    the motion of the expression load with the same formula to 1e-12 (rk4 at h = 1e-3; dop853 at
    rtol 1e-13), in the body and the space frame, on a non-principal body.  A second function
    reuses the compiled, disk-cached kernels (the callback's type is one for all functions)."""
    formula = ["-0.4*omega[0] + 0.3*sin(2*t)", "-0.4*omega[1] - 0.3*sin(2*t)", "-0.4*omega[2] + 0.5*0.3*sin(2*t)*q[0]"]
    for method, frames in (("rk4", ("body",)), ("rkmk4", ("body",)), ("dop853", ("body", "space"))):
        for frame in frames:
            scenario = _scenario([], method, rtol=1e-13, atol=1e-15)
            traj = rotlab.simulate(scenario, torque=_python_torque, frame=frame)
            assert traj.stats.failure is None and traj.work is not None
            reference = _states([{"type": "expression", "frame": frame, "torque": formula}], method, rtol=1e-13, atol=1e-15)
            assert np.max(np.abs(np.column_stack([traj.quaternion, traj.omega]) - reference)) < 1e-12, (method, frame)
    other = rotlab.simulate(_scenario([], "dop853"), torque=lambda t, q, omega: (0.0, 0.0, 0.0))
    assert np.max(np.abs(other.omega - _states([], "dop853")[:, 4:7])) == 0.0


_GAIN = 0.4  # read by _gained_torque: numba freezes its value when it compiles the function


def _gained_torque(t, q, omega):
    return -_GAIN * omega[0], -_GAIN * omega[1], -_GAIN * omega[2]


def test_a_python_torque_is_compiled_once_and_again_when_what_it_reads_changes(monkeypatch):
    """The same function gives the same compiled callback at the next call; a changed global it
    reads (numba froze its value), a changed array's contents or a rebound function compile it
    anew, so the motion follows the new value: equal to the expression with that value to 1e-12
    (rk4 at h = 1e-3); so do -0.0 for 0.0 and a new code object.  A function reading a user's
    module is compiled at each call."""
    from rotlab.scene.user_torque import user_torque

    axes = np.eye(3)
    first = user_torque(_gained_torque, "body", axes).fn
    assert user_torque(_gained_torque, "body", axes).fn is first
    for gain in (0.8, 0.4):
        monkeypatch.setattr(sys.modules[__name__], "_GAIN", gain)
        traj = rotlab.simulate(_scenario([], "rk4"), torque=_gained_torque)
        reference = _states([{"type": "expression", "frame": "body", "torque": [f"-{gain}*omega[{k}]" for k in range(3)]}], "rk4")
        assert np.max(np.abs(np.column_stack([traj.quaternion, traj.omega]) - reference)) < 1e-12, gain
    assert user_torque(_gained_torque, "body", axes).fn is user_torque(_gained_torque, "body", axes).fn
    table = np.array([0.1, 0.2, 0.3])

    def tabled(t, q, omega):
        return table[0], table[1], table[2]

    before = user_torque(tabled, "body", axes).fn
    table[1] = 0.5
    assert user_torque(tabled, "body", axes).fn is not before
    sign = 0.0

    def signed(t, q, omega):
        return math.copysign(1.0, sign), 0.0, 0.0

    before = user_torque(signed, "body", axes).fn
    sign = -0.0  # == 0.0, but not the same constant
    assert user_torque(signed, "body", axes).fn is not before
    before = user_torque(tabled, "body", axes).fn
    tabled.__code__ = tabled.__code__.replace()
    assert user_torque(tabled, "body", axes).fn is not before  # a new code object (IPython's autoreload swaps them)

    gains = types.ModuleType("gains")  # a user's module of parameters: numba reads gains.k, frozen
    gains.k = 0.1

    def from_module(t, q, omega):
        return gains.k, 0.0, 0.0

    assert user_torque(from_module, "body", axes).fn is not user_torque(from_module, "body", axes).fn


def test_python_torque_function_refusals():
    """taylor refuses a Python torque (no series) and auto then picks dop853; a function numba
    cannot compile, or one that does not return 3 numbers, is an InputError naming why."""
    scenario = _scenario([], "taylor")
    with pytest.raises(InputError, match="taylor needs the Taylor series"):
        rotlab.simulate(scenario, torque=_python_torque)
    from rotlab.methods.base import Settings
    from rotlab.methods.choose import choose_method

    chosen, reason, _ = choose_method(build_scene(_scenario([], "auto"), torque=_python_torque), "auto", Settings(), np.linspace(0, 1, 3))
    assert chosen.name == "dop853" and "Taylor series" in reason
    with pytest.raises(InputError, match=r"numba cannot compile f\(t, q, omega\): Untyped global name 'object'"):
        def f(t, q, omega):
            return object(), 0.0, 0.0
        build_scene(scenario, torque=f)
    with pytest.raises(InputError, match="must return 3 real numbers"):
        build_scene(scenario, torque=lambda t, q, omega: omega[0])
    with pytest.raises(InputError, match="frame"):
        build_scene(scenario, torque=_python_torque, frame="inertial")


def test_taylor_stops_cleanly_where_a_series_is_singular():
    """quadratic_drag from rest: √|ω|² has no Taylor series at ω = 0, so taylor stops there
    naming the load (no exception, a failure message); dop853 runs the same scene."""
    scenario = parse_scenario({"body": {"principal_moments": [1.0, 2.0, 3.0]},
                               "loads": [{"type": "quadratic_drag", "coefficient": 0.1}, {"type": "torque", "frame": "body", "value": [0.1, 0.0, 0.0]}],
                               "time": {"end": 1.0, "samples": 11}, "solver": {"method": "taylor"}})
    traj = rotlab.simulate(scenario, check=False)
    assert traj.stats.failure.startswith("loads[0] (quadratic_drag) torque x has no finite Taylor series at t = 0 s")
    traj = rotlab.simulate(scenario, method="dop853")
    assert traj.stats.failure is None and traj.omega[-1, 0] > 0.09  # ≈ 0.1 rad/s after 1 s, less the drag


GPU_FORMULAS = [  # every opcode, in the three frames' components; values that overflow, divide by 0, leave a domain
    ["-k*omega[0] + sin(t)*cos(q[1])", "tan(omega[1]) - exp(L[2]/k)", "log(abs(q[0])) + sqrt(gamma[2]) - tanh(t)"],
    ["sign(omega[2])*omega[0]**3 + omega[1]**-2", "atan2(L[0], L[1]) / (t - 1)", "min(omega[0], q[3])**0.5 - max(gamma[0], -t)"],
    ["-(-(t))", "2", "0**-1 + log(t - 1)"],
]


def test_the_gpus_formula_interpreter_gives_the_compiled_functions_values_bit_for_bit():
    """``run_program`` over ``formula_table`` (the GPU's way: a device has no CPU function to call)
    computes every load's formulas as the generated function does, bit for bit, NaN and inf
    included, at 200 random inputs and at t = 1 (a pole), run here on the CPU (the same
    libm; on a GPU the library functions are libdevice's)."""
    from rotlab.core.expressions import run_program
    from rotlab.core.formula_table import expression_programs, formula_table
    from rotlab.scene import formulas

    builder = ProgramBuilder()
    for texts in GPU_FORMULAS:
        builder.formulas(texts, {"k": 0.3}, 0.0, (-np.inf, np.inf))
    ex = builder.build(np.eye(3), np.ones(3))
    table = formula_table(expression_programs(ex))  # (the model's programs read back, as the GPU's table is made)
    assert np.array_equal(table, formula_table(builder.programs))  # (… which are the generated function's)
    compiled = _generated(formulas.compiled(builder.programs, checked=False).address, formulas.constant_values(builder.programs))
    rng = np.random.default_rng(3)
    points = [rng.normal(0.0, 2.0, opcodes.N_INPUTS) for _ in range(200)] + [np.r_[1.0, np.zeros(opcodes.N_INPUTS - 1)]]
    special = 0
    for x in points:
        for load in range(len(GPU_FORMULAS)):
            for component in range(3):
                expected = compiled(load, component, *x)
                got = run_program(table, load, component, tuple(x))
                assert np.array_equal(got, expected, equal_nan=True), (load, component, x, got, expected)
                special += not np.isfinite(expected)
    assert special > 100  # NaN and inf were compared, not only finite values


def test_the_formula_table_of_events_interprets_each_events_formulas_as_their_compiled_function():
    """Events have 1 + len(record) formulas each (3, 1, 2 here): the table's rows are as wide as
    the widest event, and ``run_program`` over ``block.event_inputs``' table (the GPU's way) gives
    the compiled events function's values bit for bit, NaN and inf included."""
    from rotlab.core.expressions import run_program
    from rotlab.ensemble.block import event_inputs

    events = [{"name": "a", "when": "omega[1]", "record": ["atan2(omega[0], omega[2])", "log(t - 1) * q[0]"]},
              {"name": "b", "when": "exp(L[2]) - gamma[0]**3"}, {"name": "c", "when": "tan(t)", "record": ["sqrt(q[3])/(omega[0] - 1)"]}]
    scene = build_scene(parse_scenario({"body": {"principal_moments": [1.0, 2.0, 3.0]}, "time": {"end": 1.0}, "events": events}))
    inputs, compiled = event_inputs(scene)
    assert inputs.table[0] == 3 and inputs.depth == compiled.depth >= 2
    function = _generated(inputs.fn, inputs.consts)
    rng = np.random.default_rng(11)
    special = 0
    for _ in range(200):
        x = rng.normal(0.0, 2.0, opcodes.N_INPUTS)
        for k, event in enumerate(events):
            for component in range(1 + len(event.get("record", []))):
                expected = function(k, component, *x)
                assert np.array_equal(run_program(inputs.table, k, component, tuple(x)), expected, equal_nan=True), (k, component, x)
                special += not np.isfinite(expected)
    assert special > 50


def test_the_formula_table_of_a_gyrostat_holds_its_drives_after_its_loads():
    """Driven rotors' formulas (pd_control) are the programs' loads after the formula loads'
    (``Drives.offset``): the table of both row sets, in that order, interprets each as the scene's
    compiled function does, bit for bit (``model_formula_table``, which ``gpu._model_to_device`` calls)."""
    from rotlab.config.loader import read_toml
    from rotlab.core.expressions import run_program
    from rotlab.core.formula_table import model_formula_table
    from tests.conftest import CONFIGS

    raw = read_toml(CONFIGS / "wheel_slew.toml")
    raw["loads"] = [{"type": "expression", "frame": "space", "torque": ["1e-4*sin(t)", "-2e-4*omega[2]", "L[0]*q[1]"]}]
    model = build_scene(parse_scenario(raw, source="wheel_slew.toml")).model
    ex, drives = model.expressions, model.drives
    assert ex is not None and drives is not None and drives.offset == ex.rows.shape[0] == 1
    table, depth = model_formula_table(model)
    assert depth == max(ex.depth, drives.ex.depth)
    compiled = _generated(ex.fn, ex.consts)
    rng = np.random.default_rng(5)
    programs = [(0, c) for c in range(3)] + [(drives.offset + j, 0) for j in range(drives.axes.shape[0])]
    for _ in range(100):
        x = rng.normal(0.0, 1.0, opcodes.N_INPUTS)
        for load, component in programs:
            assert np.array_equal(run_program(table, load, component, tuple(x)), compiled(load, component, *x), equal_nan=True)


def test_programs_that_differ_in_their_constants_only_share_one_compiled_function():
    """The generated function reads the programs' constants from its argument (in the order the
    Taylor-mode code indexes them, ``Expressions.consts``), so formulas with other values of their
    named constants reuse it, each with its own values (to rounding, against Python's math)."""
    from rotlab.scene import formulas

    texts = ["-k*omega[0] + k**2*sin(t)", "atan2(k, omega[1]) - 2.5", "k*gamma[2]**3"]
    x = np.array([0.4, 1.1, -0.6, 0.2, 0.5, 0.5, 0.5, 0.5, 0.3, -0.2, 0.9, 1.0, 2.0, 3.0])
    functions = set()
    for k in (0.3, -1.7):
        builder = ProgramBuilder()
        builder.formulas(texts, {"k": k}, 0.0, (-np.inf, np.inf))
        np.testing.assert_array_equal(formulas.constant_values(builder.programs), builder.slots.values)
        function = formulas.compiled(builder.programs)
        functions.add(function)
        values = [_generated(function.address, np.array(builder.slots.values))(0, c, *x) for c in range(3)]
        expected = [-k * x[1] + k**2 * math.sin(x[0]), math.atan2(k, x[2]) - 2.5, k * x[10]**3]
        assert values == pytest.approx(expected, rel=1e-15, abs=0)
    assert len(functions) == 1


def test_a_loads_three_values_in_one_call_are_its_three_calls_bit_for_bit():
    """``call_load_formulas`` (one call of the generated function, the three components computed
    together, ``opcodes.ALL_COMPONENTS``) gives the three ``call_formulas`` values bit for bit —
    NaN, ±inf and −0.0 included — and leaves the same fault record (the last non-finite
    component's: they are checked in the same order)."""
    from numba import njit

    from rotlab.core import faults
    from rotlab.core.expressions import call_formulas, call_load_formulas, constants_address
    from rotlab.scene import formulas

    @njit
    def together(fn, consts, x):
        return call_load_formulas(fn, constants_address(consts), 1, x)

    @njit
    def apart(fn, consts, x):
        address = constants_address(consts)
        return call_formulas(fn, address, 1, 0, x), call_formulas(fn, address, 1, 1, x), call_formulas(fn, address, 1, 2, x)

    builder = ProgramBuilder()
    builder.formulas(["-k*omega[0]", "0", "k*t"], {"k": 0.3}, 0.0, (-np.inf, np.inf))
    builder.formulas(["log(omega[0])*k*cos(n*t)", "sqrt(omega[1])/omega[2] - k*cos(n*t)", "exp(k*t)*cos(n*t)*q[0]"], {"k": 0.7, "n": 1.3},
                     0.0, (-np.inf, np.inf))
    fn, consts = formulas.compiled(builder.programs).address, np.array(builder.slots.values)
    rng = np.random.default_rng(11)
    x = rng.standard_normal((4000, opcodes.N_INPUTS)) * np.exp(rng.uniform(-8, 8, (4000, 1)))
    x[:400, 2] = -0.0
    x[400:800, 0] = 1e3  # exp(k t) overflows
    nonfinite = 0
    for row in x:
        inputs = tuple(row.tolist())
        faults.clear()
        one = np.array(together(fn, consts, inputs))
        first = faults.take()
        three = np.array(apart(fn, consts, inputs))
        assert one.tobytes() == three.tobytes() and first == faults.take()
        nonfinite += not np.all(np.isfinite(one))
    assert 800 <= nonfinite < 4000  # (the non-finite values and their records were compared, not only finite ones)


def test_a_constant_exponent_stays_a_literal_and_a_repeated_constant_is_one_slot():
    """A POW's constant exponent is written into the generated source (as POWI's integer), so the
    compiler turns ``x**0.5`` into a square root, exactly, as it did when every constant was a
    literal (read from ``c``, the library's pow differs in the last bit for ~1 input in 1,000: a
    run's bits changed).  A named constant is one slot of ``c`` however often it is written (six
    times in ``bdot_detumbling``'s field: the compiler then computes cos(n t) once; with a slot
    each, the load cost 2.8× a step), and two names keep two slots when their values are equal
    (kp = kd in a sweep over kp), so the function stays shared."""
    from rotlab.scene import formulas

    builder = ProgramBuilder()
    builder.formulas(["abs(omega[0])**0.5", "k*cos(n*t) + k*sin(n*t)*omega[1]", "abs(omega[2])**h"], {"k": 0.3, "n": 1.1, "h": 0.5},
                     0.0, (-np.inf, np.inf))
    assert builder.slots.values == [0.5, 0.3, 1.1]  # (the exponents, literals, by value)
    functions = set()
    for a, b in ((0.2, 0.3), (0.2, 0.2), (0.3, 0.3)):
        other = ProgramBuilder()
        other.formulas(["a*omega[0] + b*omega[1]", "a*b", "b - a"], {"a": a, "b": b}, 0.0, (-np.inf, np.inf))
        assert other.slots.values == [a, b]
        functions.add(formulas.compiled(other.programs))
    assert len(functions) == 1
    np.testing.assert_array_equal(formulas.constant_values(builder.programs), builder.slots.values)
    source = formulas.module_source(builder.programs)
    assert source.count("(0.5)") == 2 and "c[1] * math.cos((c[2] * x0))" in source
    function = _generated(formulas.compiled(builder.programs).address, np.array(builder.slots.values))
    x = np.random.default_rng(7).standard_normal((20000, opcodes.N_INPUTS)) * np.exp(np.random.default_rng(8).uniform(-30, 30, (20000, 1)))
    for row in x:
        assert function(0, 0, *row) == math.sqrt(abs(row[1])) and function(0, 2, *row) == math.sqrt(abs(row[3]))
