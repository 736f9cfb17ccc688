"""The maximal Lyapunov exponent of a scenario's motion, by Benettin's renormalisation on the
tangent map of the method (Benettin, Galgani, Giorgilli & Strelcyn, Meccanica 15, 1980).

Over each sample interval [t_k, t_{k+1}] the method's own flow Φ_k (``Method.local_solution``:
its steps from any state) carries the state x_k and a neighbour x_k + δ v_k, |v_k| = 1:

    w = P (Φ_k(x_k + δ v_k) − Φ_k(x_k)) / δ,    s_k = |w|,    v_{k+1} = w / s_k,
    λ(t_k) = Σ_{j<k} ln s_j / (t_k − t_0),

the finite difference approximating the method's tangent map to O(δ) (``DELTA``), renormalised
at every sample, so the neighbour never leaves the linear regime.  ``divergence`` is the cross-check:
two whole runs started ``separation`` apart, their distance measured and reset every few seconds.

Phase space and norm: the state (Λ, ω) (principal body frame), ‖(δΛ, δω)‖² = |δΛ|² + |δω|²/Ω²,
Ω the scene's rate scale (a dimensionless norm).  P removes δΛ's component along Λ: the deviation
stays tangent to |Λ| = 1, where the motion lives.  The invariants (energy, |L| or L along the
vertical) are not imposed on the deviation: a deviation across them makes the neighbour run at
another frequency, which grows linearly, not exponentially, so the maximal exponent is the same;
for an integrable motion λ(T) decays as ~ln(Ω T)/T (the tests hold it to that).
The closed form (``exact``) starts only from the scene's initial state, so a scenario that runs
``exact`` is measured with ``taylor`` (or ``dop853``) at its tolerances instead (``method`` says).
A scenario's ``[[events]]`` are not evaluated (a terminal event does not end the measurement).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

import numpy as np
from numba import literally, njit

from rotlab.config.models import Scenario
from rotlab.core.kernel_status import OK, state_status
from rotlab.ensemble.method_calls import local_state
from rotlab.errors import RunFailure

DELTA = 1e-8  # the finite difference of the tangent map, in the scaled norm
CALL_SECONDS = 0.05  # the compiled loop's calls last about this long (the number of intervals a call doubles or halves)
SEED = 20261126  # the first deviation's direction: reproducible
CLOSED_FORM_STAND_INS = ("taylor", "dop853")  # measured instead of ``exact`` (module docstring)


@dataclass(frozen=True)
class Lyapunov:
    """The maximal Lyapunov exponent (1/s) and its convergence history λ(t)."""

    exponent: float  # 1/s, λ at the end of the run
    t: np.ndarray  # s, the sample times after t0
    history: np.ndarray  # 1/s, λ(t)
    method: str  # the method whose tangent map was used, and why
    interval: float  # s, between renormalisations (the sample interval)
    rate_scale: float  # Ω, 1/s: the norm's scale for ω

    @property
    def spread(self) -> float:
        """max − min of λ(t) over the second half of the run (1/s): how far it has settled."""
        half = self.history[self.history.shape[0] // 2:]
        return float(half.max() - half.min()) if half.size else math.nan

    def __str__(self) -> str:
        n = self.t.shape[0]
        lines = [f"maximal Lyapunov exponent: {self.exponent:.6g} 1/s over {self.t[-1] - self.t[0] + self.interval:.6g} s",
                 f"method: {self.method}; renormalised every {self.interval:.3g} s; norm |δΛ|² + |δω|²/Ω², Ω = {self.rate_scale:.4g} 1/s",
                 f"convergence: λ varied by {self.spread:.3g} 1/s over the second half of the run"
                 + (" — not settled (more than a fifth of λ): lengthen --duration" if self.spread > 0.2 * abs(self.exponent) else "")]
        if self.exponent > 0.0:
            lines.append(f"Lyapunov time 1/λ: {1.0 / self.exponent:.4g} s")
        lines.append("history: " + ", ".join(f"λ({self.t[k]:.4g} s) = {self.history[k]:.4g}" for k in sorted({n // 8, n // 4, n // 2, n - 1})))
        return "\n".join(lines)


def lyapunov(scenario: Scenario | str | Path, *, duration: float | None = None, overrides: Mapping[str, Any] | None = None) -> Lyapunov:
    """The maximal Lyapunov exponent of ``scenario`` (object or file) over ``duration`` (s, else
    its own span), renormalised at every sample (module docstring)."""
    from rotlab.api import _plan, scenario_of
    from rotlab.ensemble.method_calls import entry_for_method, local_scratch, local_solver
    from rotlab.methods.registry import get_method
    from rotlab.methods.stepping import state_failure_after
    from rotlab.scene.scene import build_scene

    scenario = scenario_of(scenario, duration=duration, overrides=overrides)
    scene = build_scene(scenario.model_copy(update={"events": []}))  # (not evaluated: a terminal one must not lift the step budget's check)
    chosen, reason, settings, t = _plan(scene)
    why = f"{chosen.name} ({reason})"
    if chosen.name == "exact":
        stand_in = next(get_method(name) for name in CLOSED_FORM_STAND_INS if get_method(name).unsupported(scene) is None)
        chosen, why = stand_in, f"{stand_in.name} at the scenario's tolerances (exact's closed form cannot start from a neighbouring state)"
    omega_scale = scene.rate_scale or 1.0
    scale = np.r_[np.ones(4), np.full(3, omega_scale)]  # the units of the state's Λ and ω (rad/s)
    x = scene.state0.copy()
    v = np.random.default_rng(SEED).standard_normal(x.shape[0])
    _tangent(v, x)
    v /= _scaled_norm(v, scale)
    growth = np.empty(t.shape[0] - 1)
    times = np.ascontiguousarray(t, dtype=float)
    args = (local_solver(chosen, scene, times, settings), scene.model, times, x, v, scale, growth, local_scratch(x.shape[0]),
            local_scratch(x.shape[0]))
    renormalised = entry_for_method(_renormalised, chosen.name, *args, 0, 0)
    k, chunk = 0, 1
    while k < growth.shape[0]:  # in calls of about CALL_SECONDS: Ctrl-C is heard between them
        started = time.perf_counter()
        status, k = renormalised(chosen.name, *args, k, min(growth.shape[0], k + chunk))
        if status != OK:  # (a run's rule, and its words)
            raise RunFailure(f"{state_failure_after(status, float(t[k]), float(t[k + 1]), x)}: no exponent")
        chunk = chunk * 2 if time.perf_counter() - started < CALL_SECONDS / 2 else max(1, chunk // 2)
    elapsed = np.asarray(t[1:], dtype=float) - float(t[0])
    history = np.cumsum(growth) / elapsed
    return Lyapunov(float(history[-1]), elapsed + float(t[0]), history, why, float(t[1] - t[0]), omega_scale)


def divergence(scenario: Scenario | str | Path, *, duration: float | None = None, overrides: Mapping[str, Any] | None = None,
               separation: float = 1e-9, interval: float = 5.0) -> float:
    """The cross-check of ``lyapunov`` (1/s): a second run started ``separation`` away (scaled
    norm, the same random direction), whole runs of ``interval`` seconds — the scenario's method
    and sample grid, not the per-sample tangent map — after each of which the distance d is
    measured and the neighbour put back at ``separation`` along it (Benettin's renormalisation at a
    long interval, as Wolf et al. 1985 do with two trajectories):  λ ≈ Σ ln(d / separation) / T.
    ``interval`` short enough that d stays small (λ · interval ≲ 10)."""
    import rotlab
    from rotlab.api import scenario_of
    from rotlab.config.loader import parse_scenario

    base = scenario_of(scenario, duration=duration, overrides=overrides)
    start, end = base.time.start, base.time.end
    raw = base.model_dump(mode="json", exclude_unset=True)
    raw.pop("events", None)  # (a terminal event would end the runs)
    rate = (base.time.sample_count - 1) / (end - start)

    def run(t0: float, q: np.ndarray, w: np.ndarray):
        """The scenario from the attitude Λ/|Λ| and ω (user's frames) at t0, over ``interval`` at the
        base's sample rate (a method that does not keep |Λ|, rk4, ends an interval off the unit sphere)."""
        raw["initial"] = {"quaternion": (q / np.linalg.norm(q)).tolist(), "omega": w.tolist()}
        raw["time"] = {"start": t0, "end": min(t0 + interval, end), "sample_rate": rate}
        return rotlab.simulate(parse_scenario(raw, source="divergence"))

    first = rotlab.simulate(base, overrides={"time.end": start + min(interval, end - start)})
    here = run(start, first.quaternion[0], first.omega[0])
    omega_scale = here.scene.rate_scale or 1.0
    u = np.random.default_rng(SEED).standard_normal(7)
    q, w = here.quaternion[0], here.omega[0]
    u[:4] -= (u[:4] @ q) * q
    dq, dw = u[:4], u[4:] * omega_scale
    total = 0.0
    while True:
        size = math.sqrt(float(dq @ dq) + float(dw @ dw) / omega_scale**2)
        there = run(float(here.t[0]), q + dq * separation / size, w + dw * separation / size)
        q, w = here.quaternion[-1], here.omega[-1]
        other = there.quaternion[-1] * (1.0 if there.quaternion[-1] @ q >= 0.0 else -1.0)
        dq, dw = other - q, there.omega[-1] - w
        total += math.log(math.sqrt(float(dq @ dq) + float(dw @ dw) / omega_scale**2) / separation)
        t0 = float(here.t[-1])
        if t0 >= end - 1e-9 * max(1.0, abs(end)):
            return total / (end - start)
        here = run(t0, q, w)


@njit(cache=True)
def _renormalised(method, solver, model, t, x, v, scale, growth, a, b, start, stop):
    """Benettin's loop (module docstring) over the sample intervals [t_k, t_k+1], k = start …
    stop − 1, from the state ``x`` at t_start and the unit deviation ``v`` (both updated in place),
    the flow ``local_state`` of the method named ``method`` (``solver`` its settings; ``a``,
    ``b``: ``LocalScratch`` of the two solutions): growth[k] = ln s_k.  (OK, stop), or (status, k)
    where a solution over [t_k, t_k+1] is not a valid state (``state_status``), x then still the
    state at t_k."""
    width = x.shape[0]
    shifted, w = np.empty(width), np.empty(width)
    for k in range(start, stop):
        for j in range(width):
            shifted[j] = x[j] + DELTA * v[j]
        local_state(literally(method), solver, model, x, t[k], t[k + 1], a)
        local_state(literally(method), solver, model, shifted, t[k], t[k + 1], b)
        status = state_status(a.y)
        if status == OK:
            status = state_status(b.y)
        if status != OK:
            return status, k
        for j in range(width):
            w[j] = (b.y[j] - a.y[j]) / DELTA
        _tangent(w, a.y)
        size = _scaled_norm(w, scale)
        growth[k] = math.log(size)
        for j in range(width):
            x[j], v[j] = a.y[j], w[j] / size
    return OK, stop


@njit(cache=True, inline="always")
def _tangent(d, x):
    """``d`` without its Λ component along Λ (tangent to |Λ| = const) and without the work W
    (and rotors' momenta), in place."""
    along = (d[0] * x[0] + d[1] * x[1] + d[2] * x[2] + d[3] * x[3]) / (x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + x[3] * x[3])
    for j in range(4):
        d[j] -= along * x[j]
    for j in range(7, d.shape[0]):
        d[j] = 0.0


@njit(cache=True, inline="always")
def _scaled_norm(d, scale):
    """‖(δΛ, δω)‖ = √(|δΛ|² + |δω|²/Ω²): ``scale`` (1, 1, 1, 1, Ω, Ω, Ω)."""
    total = 0.0
    for j in range(7):
        total += (d[j] / scale[j]) ** 2
    return math.sqrt(total)
