"""``rotlab.core.event_root``: the root of an event inside a sample interval, as a state machine
fed with values.  Its Brent iterates are SciPy's ``brentq`` to the last bit (the single run
located events with SciPy's before, and the ensemble kernels locate them with this one), and its
verdicts separate a root from a sign change through a pole, a value that is not finite and a
root at the sample itself."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from rotlab.core import event_root as root


def locate(g, g0: float, span: float, xtol: float) -> tuple[int, float, int]:
    """(verdict, τ, evaluations) of the state machine on g."""
    s = np.empty(root.ROOT_STATE)
    tau, calls = root.locate_start(s, g0, span, xtol), 0
    while True:
        verdict, tau = root.locate_next(s, g(tau))
        calls += 1
        if verdict != root.PENDING:
            return verdict, tau, calls


def _family(kind: int, a: float, b: float, r: float, span: float):
    x0 = r * span
    return [lambda x: (x - x0) * (1.0 + a * a) + b * (x - x0) ** 3,
            lambda x: math.sin(3.0 * (x / span - r)) * (1.0 + a * a) + 0.01 * b * (x / span - r) ** 2,
            lambda x: math.exp(a * x / span) - math.exp(a * r),
            lambda x: math.tanh(20.0 * (x / span - r)) + 1e-3 * b][kind]


def _bracketed(rng, count: int, lowest_span: float, scale: float = 1.0):
    """``count`` functions of the four families, times ``scale``, that change sign over their span
    (10^lowest_span … 10): (g, g(0), span) each."""
    found = 0
    while found < count:
        a, b = rng.normal(size=2)
        kind, r, span = found % 4, rng.uniform(0.01, 0.99), 10.0 ** rng.uniform(lowest_span, 1)
        g = lambda x, f=_family(kind, a, b, r, span): scale * f(x)  # noqa: E731
        g0, g1 = g(0.0), g(span)
        if g0 == 0.0 or g1 == 0.0 or (g0 > 0) == (g1 > 0):
            continue
        yield g, g0, span
        found += 1


def test_the_root_is_scipys_brentq_to_the_last_bit():
    """2,000 bracketed roots of four families (polynomial, trigonometric, exponential, a steep
    tanh), spans 1e-6 … 10, tolerances 1e-14 … 1e-11: the same τ, bit for bit."""
    rng = np.random.default_rng(1)
    for g, g0, span in _bracketed(rng, 2000, -6):
        xtol = 1e-14 * 10.0 ** rng.uniform(0, 3)
        verdict, tau, _ = locate(g, g0, span, xtol)
        assert verdict == root.ROOT and tau == brentq(g, 0.0, span, xtol=xtol, rtol=root.RTOL)


@pytest.mark.parametrize("scale", [1e-120, 1e-150, 1e-300])
def test_values_so_small_that_brents_products_underflow_give_scipys_root(scale):
    """g = scale·(four families): the inverse quadratic step's denominator underflows to 0.  SciPy's
    C divides to inf and bisects; the compiled loop raised ZeroDivisionError (a traceback from an
    event of ``1e-120*omega[1]``, and a sweep that wrote nothing).  Now SciPy's τ, bit for bit."""
    for g, g0, span in _bracketed(np.random.default_rng(2), 200, -3, scale):
        verdict, tau, _ = locate(g, g0, span, 1e-12)
        assert verdict == root.ROOT and tau == brentq(g, 0.0, span, xtol=1e-12, rtol=root.RTOL)


def test_a_sign_change_through_a_pole_is_not_a_root():
    g = lambda x: 1.0 / (x - 0.3)  # noqa: E731  (−1/0.3 at 0, +1/0.7 at 1, through ±∞ at 0.3)
    verdict, tau, _ = locate(g, g(0.0), 1.0, 1e-14)
    assert verdict == root.POLE and abs(tau - 0.3) < 1e-13


@pytest.mark.parametrize("g1, verdict", [(float("nan"), root.NOT_FINITE), (float("inf"), root.NOT_FINITE), (0.0, root.AT_SAMPLE),
                                         (-2.0, root.AT_SAMPLE)])
def test_the_end_of_the_interval_decides_first(g1, verdict):
    """g(span) not finite, zero, or of g(0)'s sign (the local solution meets 0 at the sample, to
    its rounding): one evaluation, at the span."""
    assert locate(lambda x: g1, -1.0, 0.5, 1e-14) == (verdict, 0.5, 1)


def test_the_time_tolerance_is_relative_to_the_interval_and_positive_at_zero():
    assert root.time_tolerance(100.0, 100.5) == pytest.approx(1.005e-12, rel=1e-15)
    assert root.time_tolerance(0.0, 0.0) > 0.0


def test_locating_events_imports_no_scipy_optimize():
    """The root is rotlab's own (SciPy's optimize package cost a run with events 24 MB and 0.4 s)."""
    import subprocess
    import sys

    from tests.conftest import CONFIGS

    code = ("import sys, rotlab\n"
            f"traj = rotlab.simulate({str(CONFIGS / 'dzhanibekov.toml')!r}, method='rk4', overrides={{'solver.step': 1e-3, "
            "'events': [{'name': 'flip', 'when': 'omega[1]'}]})\n"
            "assert traj.events['flip'].count >= 8, traj.events['flip'].count\n"
            "assert 'scipy.optimize' not in sys.modules\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
