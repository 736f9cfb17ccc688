"""Which method runs a scene: the user's choice (checked), or ``auto`` with its reason.

``auto`` takes, among the methods that apply to the scene, the one with the least expected total
cost (``rotlab.methods.cost``: measured per-call, per-step and per-sample costs, a priori step
counts) whose expected max error is within ``ACCURACY_FACTOR`` × rtol; when none is (a stepping
method's rounding floor near a separatrix, rtol below what exact gives), the one with the
smallest expected error.  Candidates:

  exact      torque-free bodies and the Lagrange top: set-up + cost per sample, no steps;
  dmv        torque-free bodies, orders 8, 10, 12, at the a priori step that meets rtol;
  taylor     every scene, at local tolerance rtol / ``TAYLOR_MARGIN`` (its global error is up to
             ~20× its local tolerance on fast spinners: configs/lagrange.toml, general.toml; near
             a separatrix rtol / the amplification), the cheapest order from Jorba–Zou's to 3 above;
  splitting  conservative scenes with forces, orders 4, 6, 8; rk4 every scene (both only win at loose rtol:
             they then derive their step from their own tolerance probe).

A stepping method whose numba kernel has not run yet in this process also pays for loading it
(``cost.first_use_seconds``), shared among the runs the process is expected to make (as many
as it has made): a single ``rotlab run`` of a Lagrange top or a free body then evaluates the exact
solution in milliseconds rather than spend ~0.3 s or more on numba, while a sweep or a loop over
``rotlab.simulate`` moves to the cheaper stepper once the load is worth it.

``dop853`` and ``rkmk4`` are never cheaper than ``taylor`` at equal error on the bench
(docs/benchmarks.md), so ``auto`` does not consider them.  The choice costs a few dozen float
operations per candidate (~30–60 µs in Python) and is cached by the numbers it depends on (body,
initial state, loads, samples, settings): a sweep, a benchmark or a loop over ``rotlab.simulate``
pays for it once (a look-up: a few µs).
"""

from __future__ import annotations

import math
import sys
from dataclasses import replace

import numpy as np

from rotlab.errors import InputError
from rotlab.methods import cost
from rotlab.methods.base import Method, Settings
from rotlab.methods.registry import METHOD_MODULES, get_method
from rotlab.scene.loads import has_switches
from rotlab.scene.scene import LAGRANGE, TORQUE_FREE, Scene

ACCURACY_FACTOR = 10.0  # "meets rtol": expected max error ≤ this × rtol
TAYLOR_MARGIN = 10.0  # taylor's local tolerance = rtol / this
# ... and never below this: a smaller tolerance asks for no more than rounding gives and only shrinks the steps
# toward the step budget (a spin exactly on a separatrix asked for 1e-303: 2·10⁸ steps, two minutes, no result)
TAYLOR_MIN_TOLERANCE = 1e-16
DMV_ORDERS = (8, 10, 12)
SPLITTING_ORDERS = (4, 6, 8)
TAYLOR_ORDER_RANGE = (4, 40)


def choose_method(scene: Scene, requested: str, settings: Settings, t: np.ndarray) -> tuple[Method, str, Settings]:
    """(method, why it was chosen, the settings it runs with).  An explicit method that cannot
    run the scene is an input error."""
    if requested != "auto":
        if requested not in METHOD_MODULES:
            raise InputError("solver.method", f"unknown method '{requested}': choose one of auto, {', '.join(METHOD_MODULES)}")
        method = get_method(requested)
        why_not = method.unsupported(scene)
        if why_not:
            raise InputError("solver.method", f"'{requested}' cannot run this scene: {why_not}; use method = \"auto\"")
        return method, "requested in the scenario or on the command line", settings
    global _RUNS
    _RUNS += 1
    key = _choice_key(scene, settings, t)
    choice = None if key is None else _CHOICES.get(key)
    if choice is None:
        choice = auto_choice(scene, settings, t)
        if key is None:  # loads that are no plain numbers (a Python torque): not cached
            return choice
        if len(_CHOICES) >= CACHE_SIZE:
            _CHOICES.pop(next(iter(_CHOICES)))
        _CHOICES[key] = choice
    return choice


CACHE_SIZE = 512
_CHOICES: dict[tuple, tuple[Method, str, Settings]] = {}
_RUNS = 0  # auto choices made in this process (cache hits included): a process that ran k runs is expected to run ~k more
_EXPECTED_RUNS = 0  # runs this process is known to make (``expect_runs``: a sweep worker's share of the cases)
_READY: dict[tuple, bool | int] = {}  # (method, load groups) -> its kernel specialisation is loaded (True) in this process


def expect_runs(count: int) -> None:
    """Tell ``auto`` that this process will make about ``count`` runs (a sweep's cases per
    worker), so that loading a stepping method's kernel is shared among them from the first
    run rather than after as many runs have been made."""
    global _EXPECTED_RUNS
    _EXPECTED_RUNS = max(0, int(count))


def _expected_runs() -> int:
    return max(_RUNS, _EXPECTED_RUNS, 1)


def _choice_key(scene: Scene, settings: Settings, t: np.ndarray) -> tuple | None:
    """Everything the choice depends on, as numbers: the same body, state, loads, samples and
    settings get the same choice (a loop over ``rotlab.simulate`` builds a new scene each call).
    None when a load is not plain numbers (then the choice is not cached)."""
    content = scene.content_key
    if content is None:
        return None
    return (_numba_ready(), _expected_runs().bit_length(), scene.kind, content, scene.omega0.tobytes(), settings.rtol, settings.atol, settings.step,
            settings.order, settings.max_steps, t.shape[0], float(t[0]), float(t[-1]))


def work_of(scene: Scene, t: np.ndarray, omega0: np.ndarray | None = None) -> cost.Work:
    """The cost model's view of a run: span, samples, rate scale, breakpoints, load kind, floor.
    ``omega0``: the run starts with this ω (principal frame) instead of the scene's."""
    span = float(t[-1] - t[0])
    omega = (scene.omega0 if omega0 is None else omega0).tolist()
    rate = scene.rate_from(omega) or 1.0 / max(span, 1e-300)
    loads = "loads" if scene.has_work else ("forces" if scene.has_potential else "free")
    floor, amplification = 0.0, 1.0
    if scene.kind == TORQUE_FREE:
        floor, amplification = cost.separatrix(tuple(scene.moments.tolist()), tuple(omega), span, rate)
    breaks = scene.shared("breakpoints", lambda: _breakpoints(scene))
    inside = int(np.count_nonzero((breaks > min(t[0], t[-1])) & (breaks < max(t[0], t[-1])))) if breaks.size else 0
    return cost.Work(span=abs(span), samples=int(t.shape[0]), rate=rate, breakpoints=inside, loads=loads, floor=floor,
                     amplification=amplification)


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


def _breakpoints(scene: Scene) -> np.ndarray:
    from rotlab.scene.loads import breakpoints

    return breakpoints(scene.loads)


def _smooth_loads(scene: Scene) -> bool:
    """No torque that jumps or kinks where no breakpoint marks it (abs, sign, min, max in an
    expression load, ``pd_control``): a fixed step crosses such a switch at low order (``rk4`` at
    h = 1.25 ms was 1e-4 off with ``pd_control`` at rtol 1e-10), ``taylor`` and ``dop853`` stop at it."""
    return not scene.shared("load switches", lambda: has_switches(scene.loads))


def candidates(scene: Scene, settings: Settings, work: cost.Work) -> list[cost.Estimate]:
    """Every method ``auto`` considers for this scene, with its expected cost and error."""
    rtol, order = settings.rtol, settings.order
    out: list[cost.Estimate] = []
    if scene.kind in (TORQUE_FREE, LAGRANGE) and order is None:
        out.append(cost.exact_estimate(_exact_kind(scene), work))
    tolerance = max(rtol / max(TAYLOR_MARGIN, work.amplification), TAYLOR_MIN_TOLERANCE)
    if order is None or TAYLOR_ORDER_RANGE[0] <= order <= TAYLOR_ORDER_RANGE[1]:
        out.append(cost.taylor_estimate(order, tolerance, work))
    target = rtol / work.amplification  # the fixed-step methods' probes aim at rtol itself
    if scene.kind == TORQUE_FREE:
        out += [cost.fixed_step_estimate("dmv", k, k, target, work) for k in DMV_ORDERS if order in (None, k)]
    elif not scene.has_work:  # (on a free body dmv is cheaper at every order: same accuracy, cheaper steps; expression loads do work)
        out += [cost.fixed_step_estimate("splitting", k, k, target, work, probe=True) for k in SPLITTING_ORDERS if order in (None, k)]
    if order is None and _smooth_loads(scene):
        out.append(cost.fixed_step_estimate("rk4", None, 4, target, work, step_limit=2.8, probe=True))
    return out


_KERNELS = {"taylor": ("rotlab.core.taylor", "taylor_advance"), "dmv": ("rotlab.core.dmv", "dmv_advance"),
            "splitting": ("rotlab.core.splitting", "splitting_advance"), "rk4": ("rotlab.core.rk4", "rk4_advance")}


def _taylor_lever_is_none(scene: Scene) -> bool:
    """taylor's kernel is also specialised on whether a lone force goes through γ (its
    ``lever_force`` argument is an array or None): two scenes with the same load groups can need
    two specialisations (gravity with a body-frame torque, gravity with a space-frame one)."""
    from rotlab.methods.taylor import lone_force

    return scene.shared("taylor lever is none", lambda: lone_force(scene) is None)


# what a kernel is specialised on besides the model's type: (argument, is it None for this scene)
_VARIANTS = {"taylor": ("lever_force", _taylor_lever_is_none)}


def _numba_ready() -> bool:
    """Has some numba kernel run in this process (its target context is set up)?"""
    return "numba.np.arraymath" in sys.modules


def _kernel_ready(name: str, scene: Scene) -> bool:
    """Has ``name``'s kernel been compiled or loaded in this process for this scene's load
    groups?  numba specialises a kernel on the model's type (absent load groups are None), so a
    kernel loaded for a heavy body still compiles (or loads) again for a top without damping;
    and on what ``_VARIANTS`` names (taylor: whether a lone force goes through γ)."""
    module_name, attr = _KERNELS.get(name, ("", ""))
    module = sys.modules.get(module_name)
    if module is None:
        return False
    kernel = getattr(module, attr, None)
    overloads = getattr(kernel, "overloads", None)
    if overloads is None:  # not a numba dispatcher (NUMBA_DISABLE_JIT): nothing to load
        return True
    groups = scene.shared("load groups", lambda: _load_groups(scene.loads))
    argument, is_none = _VARIANTS.get(name, (None, None))
    variant = is_none(scene) if is_none else None
    key = (name, groups, variant)
    seen = _READY.get(key)  # True, or the kernel's number of specialisations when it was found absent
    if seen is True or seen == len(overloads):
        return seen is True
    model = _MODEL_TYPES.get(groups) if groups is not None else None
    if model is None:
        import numba

        model = numba.typeof(scene.model)
        if groups is not None:
            _MODEL_TYPES[groups] = model
    position = kernel.py_func.__code__.co_varnames.index(argument) if argument else -1
    ready = any(model in signature and _variant_matches(variant, signature, position) for signature in kernel.signatures)
    if groups is not None:
        _READY[key] = True if ready else len(overloads)
    return ready


def _variant_matches(variant: bool | None, signature: tuple, position: int) -> bool:
    """Whether the argument at ``position`` of a compiled ``signature`` is None exactly when
    ``variant`` says so (no variant: any signature matches)."""
    if variant is None:
        return True
    from numba import types

    return (signature[position] == types.none) == variant


def _load_groups(loads) -> tuple | None:
    """What numba's type of a scene's model depends on: which load groups are present (absent
    ones are None; rotlab builds every array alike).  None for a Python torque, whose compiled
    function is part of the type (then nothing is memoised)."""
    if loads.user is not None:
        return None
    return (len(loads.forces) > 0, len(loads.terms) > 0, len(loads.tables) > 0, loads.damping > 0.0, loads.expressions is not None)


_MODEL_TYPES: dict[tuple, object] = {}  # load groups -> numba's type of the model (numba.typeof costs ~50 µs)


def with_first_use(estimates: list[cost.Estimate], loaded: dict[str, bool], fresh: int = 0) -> list[cost.Estimate]:
    """Add the one-time cost of loading each stepping method's kernel in this process, shared
    among the runs the process is expected to make: after k runs, ~k more (a sweep or a loop over
    ``simulate`` soon makes loading the kernel worth it; a single ``rotlab run`` does not).
    ``loaded``: method → its kernel is loaded for the scene (``kernels_loaded``).  ``fresh``: the
    runs are made by a new process (a sweep worker), ``fresh`` of them, numba not yet used there."""
    if all(loaded.values()):
        return estimates
    ready = _numba_ready() and not fresh
    share = 1.0 / (fresh or _expected_runs())
    extra = {name: 0.0 if is_loaded else share * cost.first_use_seconds(name, ready) for name, is_loaded in loaded.items()}
    return [e if loaded[e.method] else e._replace(seconds=e.seconds + extra[e.method]) for e in estimates]


def kernels_loaded(estimates: list[cost.Estimate], scene: Scene) -> dict[str, bool]:
    """method → its kernel is loaded in this process for ``scene`` (``exact`` has none: True),
    asked once per method."""
    loaded: dict[str, bool] = {}
    for e in estimates:
        if e.method not in loaded:
            loaded[e.method] = e.method == "exact" or _kernel_ready(e.method, scene)
    return loaded


def _exact_kind(scene: Scene) -> str:
    if scene.kind == LAGRANGE:
        return "lagrange"
    moments = scene.moments
    distinct = len({float(x) for x in moments})
    return "axisymmetric" if distinct < 3 or np.count_nonzero(scene.omega0) <= 1 else "asymmetric"


def auto_choice(scene: Scene, settings: Settings, t: np.ndarray) -> tuple[Method, str, Settings]:
    """``auto``'s choice, not cached (``choose_method`` caches it by its inputs)."""
    name, why, chosen, _ = _auto(scene, settings, t)
    return get_method(name), why, chosen


def ensemble_choice(scene: Scene, settings: Settings, t: np.ndarray, work: cost.Work, runs: int) -> tuple[Method, str, Settings] | None:
    """``auto``'s one choice for many runs of ``scene``'s body, loads and settings from different
    initial spins, ``work`` the most demanding of them (``worst_work``; ``scene``: a run with the
    fastest spin), so that each run is expected to meet rtol.  Loading a kernel is costed as in
    new processes, shared among ``runs`` runs (a sweep's cases, not a worker's: the choice does
    not depend on the number of workers).  None when no method is expected to meet rtol there
    (each run then chooses for itself)."""
    name, why, chosen, meets = _auto(scene, settings, t, work, fresh=max(1, runs))
    return (get_method(name), why, chosen) if meets else None


def _auto(scene: Scene, settings: Settings, t: np.ndarray, work: cost.Work | None = None,
          fresh: int = 0) -> tuple[str, str, Settings, bool]:
    """(``auto_choice``'s method name, why, settings; whether it is expected to meet rtol).
    ``work``: the cost model's view of the run(s) (``work_of``); ``fresh``: made for new
    processes, loading a kernel shared among ``fresh`` runs (none is loaded there yet)."""
    kind = f"{scene.kind.replace('_', '-')} scene ({scene.kind_reason})"
    if settings.step is not None:
        return (*_fixed_step_given(scene, settings, kind), True)
    work = work_of(scene, t) if work is None else work
    no_series = get_method("taylor").unsupported(scene)
    if no_series and settings.order is None:  # a Python torque: no cost model knows its smoothness, dop853 controls its error
        return "dop853", f"auto: dop853 meets rtol = {settings.rtol:g} with error control ({no_series}); {kind}", settings, True
    estimates = candidates(scene, settings, work)
    loaded = {e.method: e.method == "exact" for e in estimates} if fresh else kernels_loaded(estimates, scene)
    runs = {name: get_method(name).unsupported(scene) is None for name in loaded}
    estimates = [e for e in with_first_use(estimates, loaded, fresh) if runs[e.method]]
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
    if best.method != "exact" and any(e.method == "exact" for e in estimates) and not any(e.method == "exact" for e in others):
        others.append(next(e for e in estimates if e.method == "exact"))
    compared = "; ".join(f"{e.label} {_seconds(e.seconds)}" + ("" if e.error <= ACCURACY_FACTOR * settings.rtol else f" (error ~{e.error:.0e})")
                         for e in others)
    floor = f"; stepping error floor near the separatrix ~{work.floor:.0e}" if work.floor > 1e-3 * settings.rtol else ""
    if not _smooth_loads(scene):
        floor += "; no fixed-step method: a load switches (abs, sign, min or max) where no breakpoint marks it"
    if not all(loaded[e.method] for e in estimates):
        floor += "; the stepping methods' times include loading their numba kernel " + ("in each worker process" if fresh else "in this process")
    why = (f"auto: {best.label}, expected {_seconds(best.seconds)}: {verdict}"
           + (f" (vs {compared})" if compared else "") + f"; {kind}{floor}")
    return best.method, why, _settings_for(best, settings), bool(meeting)


def _settings_for(best: cost.Estimate, settings: Settings) -> Settings:
    if best.method == "exact":
        return settings
    if best.method == "taylor":
        scale = best.rtol / settings.rtol
        return Settings(step=None, rtol=best.rtol, atol=settings.atol * scale, max_steps=settings.max_steps, order=best.order)
    if best.method == "dmv":  # high order: the a priori step (no probe run)
        return Settings(step=best.step, rtol=settings.rtol, atol=settings.atol, max_steps=settings.max_steps, order=best.order)
    # low order: the method's own tolerance probe is worth its cost on the long runs these are
    return Settings(step=None, rtol=settings.rtol, atol=settings.atol, max_steps=settings.max_steps, order=best.order)


def _fixed_step_given(scene: Scene, settings: Settings, kind: str) -> tuple[str, str, Settings]:
    """``solver.step`` with ``auto``: the fixed-step method made for the scene."""
    if scene.kind == TORQUE_FREE:
        name = "dmv"
    elif not scene.has_work:
        name = "splitting"
    else:
        name = "rk4"
    return name, f"auto: solver.step = {settings.step:g} s given: {name}, the fixed-step method for this {kind}", settings


def _seconds(x: float) -> str:
    return f"{x * 1e3:.2g} ms" if x < 1e-3 else (f"{x * 1e3:.3g} ms" if x < 1.0 else f"{x:.3g} s")  # (no µ: the viewer's font lacks it)
