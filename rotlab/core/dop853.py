"""Adaptive Dormand–Prince 8(5,3) with 7th-order dense output (Hairer, Nørsett & Wanner,
"Solving ODEs I", §II.10), compiled.

Step: 12 stages, y₁ = y₀ + h Σ b_j k_j, FSAL k₁₃ = f(t + h, y₁).  Error (scaled by
sc_i = atol + rtol · max(|y₀ᵢ|, |y₁ᵢ|)):  err = |h| ‖e₅‖² / √((‖e₅‖² + 0.01 ‖e₃‖²) · n),
e₅ = Σ E5_j k_j, e₃ = Σ E3_j k_j.  Step factor 0.9 · err^(−1/8) clipped to [0.2, 10] (the power
as three square roots, correctly rounded on every target).
Dense output: 3 more stages and the degree-7 interpolant, evaluated at every sample in
(t, t + h] — so the output times never shorten a step.
The Butcher tableau is read from SciPy's published DOP853 coefficient table
(``scipy/integrate/_ivp/dop853_coefficients.py``), as a file: importing ``scipy.integrate``
costs 0.5–0.8 s, which a run would pay before its first step.
"""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path
from types import ModuleType

import numpy as np
from numba import njit
from numba.extending import overload

from rotlab.core.dynamics import all_finite, count_at_or_below, next_piece, rhs_called, rhs_llvm_inlined, state_size, store_row
from rotlab.core.kernel_status import NONFINITE, OK, STEP_TOO_SMALL, state_status
from rotlab.core.targets import gpu_overload, next_toward, on_gpu, work_matrix, work_vector


def _scipy_table() -> ModuleType:
    """SciPy's DOP853 coefficient module, executed from its file without importing its package
    (the module needs numpy alone); imported the usual way where that file is not found."""
    scipy = importlib.util.find_spec("scipy")
    path = Path(next(iter(scipy.submodule_search_locations or ())), "integrate", "_ivp", "dop853_coefficients.py") if scipy else None
    if path is None or not path.is_file():
        from scipy.integrate._ivp import dop853_coefficients

        return dop853_coefficients
    spec = importlib.util.spec_from_file_location("rotlab_scipy_dop853_coefficients", path)
    module = importlib.util.module_from_spec(spec)  # type: ignore[arg-type]
    spec.loader.exec_module(module)  # type: ignore[union-attr]
    return module


_coef = _scipy_table()
_A = np.ascontiguousarray(_coef.A, dtype=np.float64)  # (16, 16)
_C = np.ascontiguousarray(_coef.C, dtype=np.float64)  # (16,)
_E3 = np.ascontiguousarray(_coef.E3, dtype=np.float64)  # (13,)
_E5 = np.ascontiguousarray(_coef.E5, dtype=np.float64)  # (13,)
_D = np.ascontiguousarray(_coef.D, dtype=np.float64)  # (4, 16)
_STAGES = 12
_SAFETY, _MIN_FACTOR, _MAX_FACTOR = 0.9, 0.2, 10.0


@njit(cache=True, inline="always")
def _eighth_root(x):
    """x^(1/8) as three square roots: correctly rounded operations, so a GPU computes the CPU's
    bits (a library ``pow`` differs between targets in its last bit)."""
    return math.sqrt(math.sqrt(math.sqrt(x)))


@njit(cache=True)
def _rms_scaled(v, y, rtol, atol):
    s = 0.0
    for m in range(v.shape[0]):
        x = v[m] / (atol + rtol * abs(y[m]))
        s += x * x
    return math.sqrt(s / v.shape[0])


@njit(cache=True)
def initial_step(t, y, f0, t_end, rtol, atol, model):
    """Hairer's starting step: h = min(100 h₀, (0.01 / max(d₁, d₂))^(1/8))."""
    d0 = _rms_scaled(y, y, rtol, atol)
    d1 = _rms_scaled(f0, y, rtol, atol)
    h0 = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
    h0 = min(h0, t_end - t)
    n = state_size(model)
    y1 = work_vector(n)  # loops, not array expressions: those compile NumPy's ufunc machinery
    f1 = work_vector(n)
    for m in range(n):
        y1[m] = y[m] + h0 * f0[m]
    rhs_called(t + h0, y1, f1, model)
    for m in range(n):
        f1[m] -= f0[m]
    d2 = _rms_scaled(f1, y, rtol, atol) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = _eighth_root(0.01 / max(d1, d2))
    return min(100.0 * h0, h1, t_end - t)


@njit(cache=True)
def dop853_advance(y, t, h, times, out, i_start, t_end, rtol, atol, max_steps, model, counters):
    """Advance from (t, y) with trial step h (≤ 0: choose one), writing ``out[i]`` for every
    sample i ≥ i_start passed, until all samples are written or ``max_steps`` steps were tried.
    Steps end at every time in ``model.breaks`` (sorted): a load that switches or kinks there is never
    stepped over.

    ``y`` is updated in place; ``counters`` (int64[3]) accumulates [accepted, rejected, f evals].
    ``max_steps`` bounds the attempts, rejected ones included, so that the call always returns
    (Ctrl-C, ``--timeout`` and the step budget are honoured between calls).  The step floor is
    10 ulp of the larger of |t| and |t_end|: near t = 0 an ulp of t alone (~1e-322 s) would let
    a blow-up take the whole step budget.  A non-finite f(t, y) at a (re)start stops the run.
    Returns (status, next sample index, t, next trial step).
    """
    n = state_size(model)  # (8; more with driven rotors)
    K = work_matrix(16, n)
    y_new = work_vector(n)
    tmp = work_vector(n)
    F = work_matrix(7, n)
    E5v = work_vector(n)
    E3v = work_vector(n)
    i = i_start
    attempts = 0
    rejected = False
    breaks = model.breaks
    b = count_at_or_below(breaks, t)  # next breakpoint after t
    fresh = True  # K[0] = f(t, y) is due: at the start and after a step that ended on a breakpoint
    scale = max(abs(t), abs(t_end))
    min_step = 10.0 * (next_toward(scale, np.inf) - scale)
    while i < times.shape[0] and attempts < max_steps:
        if fresh:  # at the start and after a breakpoint only: rhs called; inlined at the stages (hot)
            rhs_called(t, y, K[0], model)
            counters[2] += 1
            fresh = False
            if not all_finite(K[0]):
                return NONFINITE, i, t, h
            if h <= 0.0:
                h = initial_step(t, y, K[0], t_end, rtol, atol, model)
                counters[2] += 1
        if not h >= min_step:  # NaN too
            return STEP_TOO_SMALL, i, t, h
        t_new = t + h
        limit, _, b = next_piece(t, t_end, breaks, b)
        if t_new > limit:
            t_new = limit
        h = t_new - t
        # a step ending on a breakpoint sees the loads' left limit: its stages stop just before it
        at_break = t_new == limit and limit != t_end
        t_last = next_toward(t_new, -np.inf) if at_break else t_new
        if on_gpu():
            _unrolled_stages(t, h, t_last, y, K, tmp, n, model)
        else:
            for s in range(1, _STAGES + 1):  # the last (FSAL) stage is f(t_last, y_new): A[12, :12] = B
                # ``_stage`` spelled out: called here, it ran general.toml 1.4× slower a step
                _stage_state(s, h, y, K, tmp, n)
                rhs_llvm_inlined(t_last if s == _STAGES else min(t + _C[s] * h, t_last), tmp, K[s], model)
        for m in range(n):
            y_new[m] = tmp[m]
        counters[2] += _STAGES
        for m in range(n):
            E5v[m] = 0.0
            E3v[m] = 0.0
        for j in range(_STAGES + 1):
            c5 = _E5[j]
            c3 = _E3[j]
            for m in range(n):
                E5v[m] += c5 * K[j, m]
                E3v[m] += c3 * K[j, m]
        e5 = 0.0
        e3 = 0.0
        for m in range(n):
            sc = atol + rtol * max(abs(y[m]), abs(y_new[m]))
            e5 += (E5v[m] / sc) ** 2
            e3 += (E3v[m] / sc) ** 2
        if e5 == 0.0 and e3 == 0.0:
            err = 0.0
        else:
            err = h * e5 / math.sqrt((e5 + 0.01 * e3) * n)
        if not math.isfinite(err):
            if not all_finite(y_new) and h <= min_step * 1e3:
                return NONFINITE, i, t, h
            err = 1e10
        attempts += 1
        if err < 1.0:
            counters[0] += 1
            if times[i] <= t_new:
                _dense_coefficients(t, h, t_last, y, y_new, K, F, tmp, model)
                counters[2] += 3
                while i < times.shape[0] and times[i] <= t_new:
                    if times[i] == t_new:
                        store_row(out, i, y_new)
                    else:
                        _dense_eval(F, y, (times[i] - t) / h, out[i], n)
                    i += 1
            for m in range(n):
                y[m] = y_new[m]
                K[0, m] = K[_STAGES, m]
            t = t_new
            fresh = at_break  # the next step starts from the right limit of the loads
            status = state_status(y)
            if status != OK:
                return status, i, t, h
            if err == 0.0:
                factor = _MAX_FACTOR
            else:
                factor = min(_MAX_FACTOR, _SAFETY / _eighth_root(err))
            if rejected:
                factor = min(1.0, factor)
            h *= factor
            rejected = False
        else:
            counters[1] += 1
            h *= max(_MIN_FACTOR, _SAFETY / _eighth_root(err))
            rejected = True
    return OK, i, t, h


def _unrolled_stages(t, h, t_last, y, K, tmp, n, model):
    """``_stage`` 1, 2, …, 12 on a GPU, unrolled: constant indices keep K in its registers (a loop
    puts K in local memory: 1.2–1.4× slower on an H100).  A CPU runs the loop (as fast, and half
    the compile time): ``dop853_advance`` calls this where ``on_gpu()``."""
    raise NotImplementedError("compiled only")


@overload(_unrolled_stages, inline="always")
def _unrolled_stages_cpu(t, h, t_last, y, K, tmp, n, model):
    return lambda t, h, t_last, y, K, tmp, n, model: None  # never reached: ``on_gpu()`` is False on a CPU


@gpu_overload(_unrolled_stages, inline="always")
def _unrolled_stages_gpu(t, h, t_last, y, K, tmp, n, model):
    def stages(t, h, t_last, y, K, tmp, n, model):
        _stage(1, t, h, t_last, y, K, tmp, n, model)
        _stage(2, t, h, t_last, y, K, tmp, n, model)
        _stage(3, t, h, t_last, y, K, tmp, n, model)
        _stage(4, t, h, t_last, y, K, tmp, n, model)
        _stage(5, t, h, t_last, y, K, tmp, n, model)
        _stage(6, t, h, t_last, y, K, tmp, n, model)
        _stage(7, t, h, t_last, y, K, tmp, n, model)
        _stage(8, t, h, t_last, y, K, tmp, n, model)
        _stage(9, t, h, t_last, y, K, tmp, n, model)
        _stage(10, t, h, t_last, y, K, tmp, n, model)
        _stage(11, t, h, t_last, y, K, tmp, n, model)
        _stage(12, t, h, t_last, y, K, tmp, n, model)
    return stages


@njit(cache=True, forceinline=True)
def _stage(s, t, h, t_last, y, K, tmp, n, model):
    """K[s] ← f(t + c_s h, y + h Σ_{j<s} a_sj K[j]) (time capped at ``t_last``; the last stage's is ``t_last``)."""
    _stage_state(s, h, y, K, tmp, n)
    rhs_llvm_inlined(t_last if s == _STAGES else min(t + _C[s] * h, t_last), tmp, K[s], model)


@njit(cache=True, forceinline=True)
def _stage_state(s, h, y, K, tmp, n):
    """tmp ← y + h Σ_{j<s} a_sj K[j], the state at which stage s evaluates f (its time is
    t + c_s h, capped at the step's ``t_last``); for s = 12 (a_12j = b_j) that is y_new.
    Model-free, so typed once per process; ``rhs_llvm_inlined`` follows it at each site: inlined
    by numba into one stage function per model type, ``rhs`` would be typed twice (here and for
    ``rk4``/``rkmk4``), which multiplies compile time per model type."""
    for m in range(n):
        tmp[m] = y[m]
    for j in range(s):
        a = _A[s, j] * h
        if a != 0.0:
            for m in range(n):
                tmp[m] += a * K[j, m]


@njit(cache=True)
def _dense_coefficients(t, h, t_last, y, y_new, K, F, tmp, model):
    """Stages 14–16 and the interpolant coefficients F (7 × n) of the step [t, t + h]
    (stage times capped at ``t_last``, the left limit at a breakpoint)."""
    n = state_size(model)
    for s in range(_STAGES + 1, 16):
        _stage_state(s, h, y, K, tmp, n)
        rhs_llvm_inlined(min(t + _C[s] * h, t_last), tmp, K[s], model)
    for m in range(n):
        dy = y_new[m] - y[m]
        F[0, m] = dy
        F[1, m] = h * K[0, m] - dy
        F[2, m] = 2.0 * dy - h * (K[_STAGES, m] + K[0, m])
    for r in range(4):
        for m in range(n):
            F[3 + r, m] = 0.0
        for j in range(16):
            d = _D[r, j] * h
            if d != 0.0:
                for m in range(n):
                    F[3 + r, m] += d * K[j, m]


@njit(cache=True, forceinline=True)
def _dense_eval(F, y, x, out, n):
    """The interpolant at x = (τ − t)/h ∈ [0, 1], u = 1 − x:
    y + x (F₀ + u (F₁ + x (F₂ + u (F₃ + x (F₄ + u (F₅ + x F₆))))))."""
    u = 1.0 - x
    for m in range(n):
        out[m] = y[m] + x * (F[0, m] + u * (F[1, m] + x * (F[2, m] + u * (F[3, m] + x * (F[4, m] + u * (F[5, m] + x * F[6, m]))))))


@njit(cache=True)
def dop853_local(y, t0, t1, grid, out, rtol, atol, max_steps, model, counters):
    """The local solution Φ(y, t0, t1) (``Method.local_solution``): y ← the state at t1 of the
    steps from (t0, y) at the tolerances, as a run starting there takes them (NaN where they
    fail); ``grid`` (2) and ``out`` (2, len(y)) scratch.  Over no time it is y itself (an event's
    root at its interval's start: the starting step's estimate would divide by the empty span)."""
    if t1 == t0:
        return
    grid[0], grid[1] = t0, t1
    for m in range(out.shape[1]):
        out[1, m] = math.nan
    # (an int64, not the literal 1, which numba would compile the whole advance again for)
    dop853_advance(y, t0, 0.0, grid, out, np.int64(1), t1, rtol, atol, max_steps, model, counters)
    for m in range(out.shape[1]):
        y[m] = out[1, m]
