"""The root of an event's formula inside one sample interval (``rotlab.events``), as a state
machine the caller feeds with values, so that one algorithm serves a single run (its Python
``EventWatch``, whose local solution may be Python) and the ensemble kernels (compiled, each
case its own local solution):

    s = np.empty(ROOT_STATE); x = locate_start(s, g0, span, xtol)
    while True:
        verdict, x = locate_next(s, g(x))      # g(τ) = g(Φ(y_k, t_k, t_k + τ))
        if verdict != PENDING: break

The value fed last is g at the returned x, so the caller's last local solution is the state
there.  Verdicts, with g₀ = g(0) ≠ 0 and g₁ = g(span):

    NOT_FINITE  g₁ is not finite (x = span)
    AT_SAMPLE   g₁ = 0 or sign g₁ = sign g₀: the local solution meets 0 at the sample itself,
                to its rounding (x = span)
    ROOT        Brent's root τ of g in (0, span): |δτ| ≤ xtol + RTOL |τ| (x = τ)
    POLE        g changed sign through a pole (1/x), not through 0: |g(τ)| > max(|g₀|, |g₁|)

Brent's method is scipy.optimize.brentq's (Brent 1973, in Harris's form: inverse quadratic
extrapolation or secant steps, bisection when they do not shrink the bracket fast enough) to the
last bit: ``tests/test_event_root.py`` holds the iterates equal to SciPy's on many functions.
"""

from __future__ import annotations

import math

from numba import njit

PENDING, ROOT, AT_SAMPLE, POLE, NOT_FINITE = 0, 1, 2, 3, 4
RTOL = 4.0 * 2.220446049250313e-16  # relative tolerance of the root (scipy's smallest allowed: 4 ε)
MAX_ITERATIONS = 100  # Brent's iterations (scipy's default); its root then is the last iterate

TIME_RTOL = 1e-14  # an event time's tolerance relative to |t| (``time_tolerance``)


@njit(cache=True)
def time_tolerance(t0, t1):
    """``xtol`` of a root in the sample interval [t0, t1]: TIME_RTOL max(|t0|, |t1|) (and a
    tiny floor, so that an interval at t = 0 gets a positive one)."""
    return TIME_RTOL * max(abs(t0), abs(t1)) + 1e-300


# the state: phase, iterations, xtol, g₀, g₁, then Brent's bracket (scipy's names)
_PHASE, _ITER, _XTOL, _G0, _G1, _XPRE, _XCUR, _XBLK, _FPRE, _FCUR, _FBLK, _SPRE, _SCUR = range(13)
ROOT_STATE = 13
_AT_END, _BRENT, _CHECK = 0.0, 1.0, 2.0  # phases: waiting for g(span), for Brent's iterate, for g at the root


@njit(cache=True)
def locate_start(s, g0, span, xtol):
    """Start locating the root in (0, ``span``] from g(0) = ``g0`` (≠ 0, finite) to |δτ| ≤
    ``xtol`` + RTOL |τ|; returns the first τ to evaluate g at (``span``)."""
    s[_PHASE], s[_ITER], s[_XTOL], s[_G0] = _AT_END, 0.0, xtol, g0
    s[_XPRE], s[_XCUR] = 0.0, span
    return span


@njit(cache=True)
def locate_next(s, value):
    """Feed g at the τ last returned: (verdict, τ) — ``PENDING`` and the next τ to evaluate, or
    the verdict (module docstring) and its τ."""
    phase = s[_PHASE]
    if phase == _AT_END:
        s[_G1] = value
        if not math.isfinite(value):
            return NOT_FINITE, s[_XCUR]
        if value == 0.0 or (value > 0.0) == (s[_G0] > 0.0):
            return AT_SAMPLE, s[_XCUR]
        s[_PHASE], s[_FPRE], s[_FCUR], s[_XBLK], s[_FBLK], s[_SPRE], s[_SCUR] = _BRENT, s[_G0], value, 0.0, 0.0, 0.0, 0.0
        return _brent_iterate(s)
    if phase == _BRENT:
        s[_FCUR] = value
        if s[_ITER] >= MAX_ITERATIONS:
            s[_PHASE] = _CHECK
            return PENDING, s[_XCUR]
        return _brent_iterate(s)
    # _CHECK: value is g at the root
    if not abs(value) <= max(abs(s[_G0]), abs(s[_G1])):
        return POLE, s[_XCUR]
    return ROOT, s[_XCUR]


@njit(cache=True, error_model="numpy")  # (IEEE division, as SciPy's C: a product of tiny values that underflows to 0 gives inf, and bisection)
def _brent_iterate(s):
    """One pass of Brent's loop from f(xcur) = fcur: (PENDING, the next iterate), or (PENDING,
    the root) with the phase set to check g there."""
    s[_ITER] += 1.0
    xpre, xcur, xblk, fpre, fcur, fblk, spre, scur = s[_XPRE], s[_XCUR], s[_XBLK], s[_FPRE], s[_FCUR], s[_FBLK], s[_SPRE], s[_SCUR]
    if fpre != 0.0 and fcur != 0.0 and (math.copysign(1.0, fpre) != math.copysign(1.0, fcur)):
        xblk, fblk = xpre, fpre
        spre = scur = xcur - xpre
    if abs(fblk) < abs(fcur):
        xpre, xcur, xblk = xcur, xblk, xcur
        fpre, fcur, fblk = fcur, fblk, fcur
    delta = (s[_XTOL] + RTOL * abs(xcur)) / 2.0
    sbis = (xblk - xcur) / 2.0
    if fcur == 0.0 or abs(sbis) < delta:
        s[_XPRE], s[_XCUR], s[_XBLK], s[_FPRE], s[_FCUR], s[_FBLK], s[_PHASE] = xpre, xcur, xblk, fpre, fcur, fblk, _CHECK
        return PENDING, xcur
    if abs(spre) > delta and abs(fcur) < abs(fpre):
        if xpre == xblk:  # interpolate (secant)
            stry = -fcur * (xcur - xpre) / (fcur - fpre)
        else:  # extrapolate (inverse quadratic)
            dpre = (fpre - fcur) / (xpre - xcur)
            dblk = (fblk - fcur) / (xblk - xcur)
            stry = -fcur * (fblk * dblk - fpre * dpre) / (dblk * dpre * (fblk - fpre))
        if 2.0 * abs(stry) < min(abs(spre), 3.0 * abs(sbis) - delta):  # a good short step
            spre, scur = scur, stry
        else:
            spre = scur = sbis
    else:
        spre = scur = sbis
    xpre, fpre = xcur, fcur
    if abs(scur) > delta:
        xcur += scur
    else:
        xcur += delta if sbis > 0.0 else -delta
    s[_XPRE], s[_XCUR], s[_XBLK], s[_FPRE], s[_FCUR], s[_FBLK], s[_SPRE], s[_SCUR] = xpre, xcur, xblk, fpre, fcur, fblk, spre, scur
    return PENDING, xcur
