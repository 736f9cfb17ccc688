"""Which method runs a scene: the user's choice (checked), or ``auto`` with its reason.

``auto`` asks every method of the catalog (``rotlab.methods.registry``) what it would cost on
the scene (``Method.auto_estimates``: expected wall time and max error from the cost model,
``rotlab.methods.cost``) and takes, among those expected within ``ACCURACY_FACTOR`` × rtol, the
cheapest; when none is (a stepping method's rounding floor near a separatrix, rtol below what
exact gives), the one with the smallest expected error.  A method that offers no estimate is
never chosen by cost (``rkmk4``: never cheaper than ``rk4`` or ``taylor`` at equal error on the
bench, docs/benchmarks.md); when no method's cost model covers a scene (a Python torque, a
driven rotor), ``auto`` runs the first adaptive method that supports it, which controls its own
error.

The choice is a pure function of the scenario and settings: the same in any process, after any
history, on any worker.  The expected costs are steady-state costs; loading a kernel from
numba's cache is not part of them.  ``Choices`` keeps choices by what they depend on (body,
initial state, loads, samples, settings), so a sweep, a benchmark or a loop over
``rotlab.simulate`` pays for a choice once.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from rotlab.errors import InputError
from rotlab.kept import Kept
from rotlab.methods import cost
from rotlab.methods.base import ADAPTIVE, FIXED, Method, Settings
from rotlab.methods.registry import METHODS, all_methods, get_method
from rotlab.scene.scene import TORQUE_FREE, Scene

ACCURACY_FACTOR = 10.0  # "meets rtol": expected max error ≤ this × rtol

Choice = tuple[Method, str, Settings]  # (method, why it runs, the settings it runs with)


class Choices:
    """``auto``'s choices kept by their inputs (at most ``size``, the oldest dropped first).
    ``rotlab.api`` owns the one its runs share."""

    def __init__(self, size: int = 512) -> None:
        self._kept: Kept[Choice] = Kept(size)

    def get(self, scene: Scene, settings: Settings, t: np.ndarray) -> Choice:
        """``auto_choice``, from what is kept when the same inputs were seen."""
        key = _choice_key(scene, settings, t)
        if key is None:  # a Python torque is no plain number: not kept
            return auto_choice(scene, settings, t)
        return self._kept.get(key, lambda: auto_choice(scene, settings, t))

    def clear(self) -> None:
        self._kept.clear()


def choose_method(scene: Scene, requested: str, settings: Settings, t: np.ndarray, choices: Choices | None = None) -> Choice:
    """(method, why it was chosen, the settings it runs with).  An explicit method that cannot
    run the scene is an input error.  ``choices``: where ``auto``'s choices are kept."""
    if requested != "auto":
        if requested not in METHODS:
            raise InputError("solver.method", f"unknown method '{requested}': choose one of auto, {', '.join(METHODS)}")
        method = get_method(requested)
        why_not = method.unsupported(scene)
        if why_not:
            raise InputError("solver.method", f"'{requested}' cannot run this scene: {why_not}; use method = \"auto\"")
        return method, "requested in the scenario or on the command line" + crossing_note(scene, method), settings
    return choices.get(scene, settings, t) if choices is not None else auto_choice(scene, settings, t)


def crossing_note(scene: Scene, method: Method) -> str:
    """What the run's reason adds when ``method`` steps across a formula load's switches (abs,
    sign, min, max with no breakpoint), where rtol does not bound its error (``detumbling.toml``,
    ``dop853`` at rtol 1e-9: max error 3.7e-6); empty otherwise."""
    if method.ends_steps_at_switches or not scene.formula_switches:
        return ""
    instead = next((m.name for m in all_methods() if m.ends_steps_at_switches and m.unsupported(scene) is None), None)
    return (f"; a formula switches (abs, sign, min or max) where no breakpoint marks it, and {method.name} steps across it: "
            "its error there is not bounded by rtol" + (f" ({instead} ends its steps at the switches)" if instead else ""))


def _choice_key(scene: Scene, settings: Settings, t: np.ndarray) -> tuple | None:
    """Everything the choice depends on, as numbers: the same body, state, loads, samples and
    settings get the same choice (a loop over ``rotlab.simulate`` builds a new scene each call).
    None when a load is not plain numbers (a Python torque)."""
    content = scene.content_key
    if content is None:
        return None
    return (scene.kind, content, scene.omega0.tobytes(), settings.rtol, settings.atol, settings.step, settings.order,
            settings.max_steps, t.shape[0], float(t[0]), float(t[-1]))


def work_of(scene: Scene, t: np.ndarray, omega0: np.ndarray | None = None) -> cost.Work:
    """The cost model's view of a run: span, samples, rate scale, breakpoints, load kind, floor,
    formula size.
    ``omega0``: the run starts with this ω (principal frame) instead of the scene's."""
    span = float(t[-1] - t[0])
    omega = (scene.omega0 if omega0 is None else omega0).tolist()
    rate = scene.rate_from(omega) or 1.0 / max(span, 1e-300)
    loads = "loads" if scene.has_work else ("forces" if scene.has_potential else "free")
    floor, amplification = 0.0, 1.0
    if scene.kind == TORQUE_FREE:
        floor, amplification = cost.separatrix(tuple(scene.moments.tolist()), tuple(omega), span, rate)
    breaks = scene.model.breaks
    inside = int(np.count_nonzero((breaks > min(t[0], t[-1])) & (breaks < max(t[0], t[-1])))) if breaks.size else 0
    return cost.Work(span=abs(span), samples=int(t.shape[0]), rate=rate, breakpoints=inside, loads=loads, floor=floor,
                     amplification=amplification, formula_rows=scene.formula_rows)


def worst_work(scene: Scene, t: np.ndarray, omegas: np.ndarray, floor_limit: float = math.inf) -> tuple[cost.Work | None, np.ndarray]:
    """(``work_of`` for the most demanding of the runs of ``scene`` from each initial ω in
    ``omegas`` (rows, principal frame) whose stepping error floor is at most ``floor_limit``:
    the largest rate scale, floor and amplification among them, or None when there is none;
    which rows those are).  A spin on or near a separatrix (its floor above the limit: only an
    exact solution meets rtol there) is left out, not let to set every run's step."""
    works = [work_of(scene, t, omega) for omega in omegas]
    within = np.array([w.floor <= floor_limit for w in works], dtype=bool)
    kept = [w for w, keep in zip(works, within) if keep]
    if not kept:
        return None, within
    return replace(kept[0], rate=max(w.rate for w in kept), floor=max(w.floor for w in kept),
                   amplification=max(w.amplification for w in kept)), within


def candidates(scene: Scene, settings: Settings, work: cost.Work) -> list[cost.Estimate]:
    """Every estimate ``auto`` weighs for this scene: each method that can run it, at each order
    and setting it offers (``Method.auto_estimates``)."""
    return [e for method in all_methods() if method.unsupported(scene) is None for e in method.auto_estimates(scene, settings, work)]


def auto_choice(scene: Scene, settings: Settings, t: np.ndarray) -> Choice:
    """``auto``'s choice (``Choices`` keeps it by its inputs)."""
    name, why, chosen, _ = _auto(scene, settings, t)
    return get_method(name), why, chosen


def ensemble_choice(scene: Scene, settings: Settings, t: np.ndarray, work: cost.Work) -> Choice | None:
    """``auto``'s one choice for many runs of ``scene``'s body, loads and settings from different
    initial spins, ``work`` the most demanding of them (``worst_work``; ``scene``: a run with the
    fastest spin), so that each run is expected to meet rtol.  None when no method is expected
    to meet rtol there (each run then chooses for itself)."""
    name, why, chosen, meets = _auto(scene, settings, t, work)
    return (get_method(name), why, chosen) if meets else None


def _auto(scene: Scene, settings: Settings, t: np.ndarray, work: cost.Work | None = None) -> tuple[str, str, Settings, bool]:
    """(``auto_choice``'s method name, why, settings; whether it is expected to meet rtol).
    ``work``: the cost model's view of the run(s) (``work_of``)."""
    kind = f"{scene.kind.replace('_', '-')} scene ({scene.kind_reason})"
    if settings.step is not None:
        return (*_fixed_step_given(scene, settings, kind), True)
    work = work_of(scene, t) if work is None else work
    estimates = candidates(scene, settings, work)
    if not estimates and settings.order is None:
        return _error_controlled(scene, settings, kind)
    if not estimates:
        raise InputError("solver.order", f"no method offers order {settings.order} for this {kind}; omit solver.order")
    meeting = [e for e in estimates if e.error <= ACCURACY_FACTOR * settings.rtol]
    if meeting:
        best = min(meeting, key=lambda e: e.seconds)
        verdict = f"the least expected cost for max error ≤ ~{ACCURACY_FACTOR:g}·rtol = {ACCURACY_FACTOR * settings.rtol:.0e}"
    else:
        best = min(estimates, key=lambda e: (e.error, e.seconds))
        verdict = f"no method is expected within {ACCURACY_FACTOR:g}·rtol; the smallest expected error ({best.error:.0e})"
    others = sorted((e for e in meeting if e is not best), key=lambda e: e.seconds)[:3]
    exact = [e for e in estimates if e.method == "exact"]
    if best.method != "exact" and exact and not any(e.method == "exact" for e in others):
        others.append(exact[0])  # the closed form, when there is one, is always named for comparison
    compared = "; ".join(f"{e.label} {_seconds(e.seconds)}" + ("" if e.error <= ACCURACY_FACTOR * settings.rtol else f" (error ~{e.error:.0e})")
                         for e in others)
    notes = f"; stepping error floor near the separatrix ~{work.floor:.0e}" if work.floor > 1e-3 * settings.rtol else ""
    if scene.has_switches:
        notes += "; no fixed-step method nor dop853: a load switches (abs, sign, min or max) where no breakpoint marks it"
    why = (f"auto: {best.label}, expected {_seconds(best.seconds)}: {verdict}"
           + (f" (vs {compared})" if compared else "") + f"; {kind}{notes}")
    return best.method, why, get_method(best.method).auto_settings(best, settings), bool(meeting)


def _error_controlled(scene: Scene, settings: Settings, kind: str) -> tuple[str, str, Settings, bool]:
    """No cost model covers the scene: the first adaptive method that runs it, which controls its
    own error (a Python torque: its smoothness is unknown, and ``taylor`` needs its series)."""
    runs = [m for m in all_methods() if m.stepping == ADAPTIVE and m.unsupported(scene) is None]
    if not runs:
        raise InputError("solver.method", f"no method can run this {kind}")
    why_not = next(filter(None, (m.unsupported(scene) for m in all_methods() if m.stepping == ADAPTIVE)), "no cost model covers it")
    note = crossing_note(scene, runs[0])
    claim = "runs with error control" if note else f"meets rtol = {settings.rtol:g} with error control"
    return runs[0].name, f"auto: {runs[0].name} {claim} ({why_not}); {kind}{note}", settings, True


def _fixed_step_given(scene: Scene, settings: Settings, kind: str) -> tuple[str, str, Settings]:
    """``solver.step`` with ``auto``: the fixed-step method made for the scene, the first by
    ``given_step_preference`` that can run it (free body: dmv; conservative: splitting; else rk4)."""
    ranked = sorted((m for m in all_methods() if m.stepping == FIXED and m.given_step_preference is not None),
                    key=lambda m: m.given_step_preference)
    method = next(m for m in ranked if m.unsupported(scene) is None)
    return (method.name, f"auto: solver.step = {settings.step:g} s given: {method.name}, the fixed-step method for this {kind}"
            + crossing_note(scene, method), settings)


def _seconds(x: float) -> str:
    return f"{x * 1e3:.2g} ms" if x < 1e-3 else (f"{x * 1e3:.3g} ms" if x < 1.0 else f"{x:.3g} s")  # (no µ: the viewer's font lacks it)
