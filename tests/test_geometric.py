"""Geometric integrators: splitting (orders 2–8), dmv (orders 2–12), rkmk4.

Each test states its bound.  References: dop853 at rtol 1e-13 (its own error here is ~4e-14).
No renormalisation anywhere: |Λ| − 1 is measured as integrated.
"""

from __future__ import annotations

import importlib.util
import itertools
import math
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest

import rotlab
from rotlab.core.dmv import ORDERS as DMV_ORDERS
from rotlab.core.dmv import modified_coefficients
from rotlab.core.splitting import splitting_advance
from rotlab.errors import InputError
from rotlab.methods.registry import get_method
from rotlab.methods.stepping import initial_state
from rotlab.scene.scene import build_scene
from tests.helpers import same_rotation_error, scenario

FREE = {
    "body": {"principal_moments": [1.0, 1.6, 2.2]},
    "initial": {"omega": [1.0, 0.5, 1.5], "axis_angle": [0.3, 0.2, 0.1]},
}
HEAVY = {  # asymmetric heavy top, centre of mass off every principal axis: not integrable
    "body": {"principal_moments": [1.0, 1.6, 2.2], "mass": 1.0, "center_of_mass": [0.1, 0.05, 0.3]},
    "initial": {"omega": [1.0, 0.5, 4.0], "axis_angle": [0.3, 0.2, 0.1]},
    "loads": [{"type": "gravity"}],
}
DRIVEN = {  # gravity + body and space harmonic torques + damping: time-dependent, does work
    "body": {"principal_moments": [1.0, 1.6, 2.2], "mass": 2.0, "center_of_mass": [0.05, 0.02, 0.1]},
    "initial": {"omega": [1.0, 0.5, 3.5], "axis_angle": [0.3, 0.2, 0.1]},
    "loads": [
        {"type": "gravity"},
        {"type": "harmonic_torque", "frame": "body", "amplitude": [0.3, 0.0, 0.2], "angular_frequency": 3.0, "phase": 0.5},
        {"type": "harmonic_torque", "frame": "space", "amplitude": [0.0, 0.4, 0.1], "angular_frequency": 1.3, "offset": [0.1, 0.0, 0.0]},
        {"type": "damping", "coefficient": 0.05},
    ],
}
SPAN = {"end": 5.0, "samples": 6}
REFERENCE = {"method": "dop853", "rtol": 1e-13, "atol": 1e-15}


def _run(base: dict, time: dict, **solver) -> rotlab.Trajectory:
    return rotlab.simulate(scenario(**base, time=time, solver=solver))


@pytest.fixture(scope="module")
def references() -> dict[str, rotlab.Trajectory]:
    return {name: _run(base, SPAN, **REFERENCE) for name, base in (("free", FREE), ("heavy", HEAVY), ("driven", DRIVEN))}


def _error(traj, ref) -> float:
    """max over samples of |ω − ω_ref|, |Λ − Λ_ref| and (when present) |W − W_ref|."""
    err = max(float(np.max(np.abs(traj.omega - ref.omega))), float(np.max(same_rotation_error(traj.quaternion, ref.quaternion))))
    if ref.work is not None:
        err = max(err, float(np.max(np.abs(traj.work - ref.work))))
    return err


# dmv order → steps per second n (every offered order has one: see the test below)
DMV_STEPS = {2: 8, 4: 16, 6: 8, 8: 8, 10: 3, 12: 2}
# (method, order, steps per second n): errors at h = 1/n and 1/(2n), both far above the reference's
ORDER_CASES = [
    ("splitting", 2, 10),
    ("splitting", 4, 10),
    ("splitting", 6, 10),
    ("splitting", 8, 4),
    *[("dmv", order, DMV_STEPS[order]) for order in DMV_ORDERS],
    ("rkmk4", None, 20),
]


def test_dmv_convergence_cases_are_exactly_the_offered_orders():
    assert sorted(DMV_STEPS) == sorted(DMV_ORDERS) and DMV_ORDERS[0] == 2


@pytest.mark.parametrize("method, order, n", ORDER_CASES)
def test_convergence_order_on_the_free_asymmetric_body(references, method, order, n):
    """Halving h divides the error by 2^p: measured order within ±0.2 of p (p = 4 for rkmk4),
    and the error at h/2 at least 30× above the reference's own (~4e-14)."""
    p = 4 if order is None else order
    coarse, fine = (_error(_run(FREE, SPAN, method=method, order=order, step=1.0 / m), references["free"]) for m in (n, 2 * n))
    assert fine > 30 * 4e-14
    assert abs(math.log2(coarse / fine) - p) < 0.2, (coarse, fine, coarse / fine)


def test_splitting_with_kicks_is_fourth_order_on_the_heavy_top(references):
    """The kicks enter at the right place and sign: order 4 (±0.2) for gravity, off-axis centre of mass."""
    coarse, fine = (_error(_run(HEAVY, SPAN, method="splitting", order=4, step=1.0 / m), references["heavy"]) for m in (20, 40))
    assert abs(math.log2(coarse / fine) - 4) < 0.2, (coarse, fine)


@pytest.mark.parametrize(
    "method, order, base",
    [("splitting", 2, FREE), ("splitting", 8, FREE), ("splitting", 4, HEAVY), ("dmv", 4, FREE), ("dmv", max(DMV_ORDERS), FREE), ("rkmk4", None, FREE), ("rkmk4", None, DRIVEN)],
    ids=["splitting2-free", "splitting8-free", "splitting4-heavy", "dmv4-free", "dmv-highest-free", "rkmk4-free", "rkmk4-driven"],
)
def test_quaternion_norm_stays_at_rounding_level(method, order, base):
    """10^5 steps (h = 0.01): ||Λ| − 1| < 1e-13 at every sample, without renormalisation."""
    traj = _run(base, {"end": 1000.0, "samples": 1001}, method=method, order=order, step=0.01)
    assert traj.stats.steps == 100_000
    assert np.max(np.abs(traj.invariants["quaternion_norm"])) < 1e-13


def _halves(x: np.ndarray) -> tuple[float, float]:
    half = x.shape[0] // 2
    return float(np.max(np.abs(x[1 : half + 1]))), float(np.max(np.abs(x[half + 1 :])))


def test_splitting_energy_error_is_bounded_without_drift():
    """Free body, order 2, h = 0.01, 10^6 steps: the max energy error of the second half is within
    10 % of the first half's (bounded O(h²) oscillation, ~4e-6 here), and rk4 on the same run,
    which drifts, fails that very criterion."""
    span = {"end": 10_000.0, "samples": 10_001}
    first, second = _halves(_run(FREE, span, method="splitting", order=2, step=0.01).invariants["energy"])
    assert second < 1.1 * first and first < 1e-5
    rk4_first, rk4_second = _halves(_run(FREE, span, method="rk4", step=0.01).invariants["energy"])
    assert rk4_second > 1.5 * rk4_first


@pytest.mark.parametrize("order", [2, 4, max(DMV_ORDERS)])
def test_dmv_energy_is_conserved_to_rounding_without_drift(order):
    """Free body, h = 0.01, 10^6 steps: |ΔH|/H < 2e-13 throughout — a random walk of rounding
    errors (~√N ε), no truncation drift: DMV conserves its modified energy exactly, hence H (an
    O(h²) method without that property sits at ~1e-5 here) — and the second half's max exceeds
    the first half's by less than 1e-13."""
    traj = _run(FREE, {"end": 10_000.0, "samples": 10_001}, method="dmv", order=order, step=0.01)
    first, second = _halves(traj.invariants["energy"])
    assert max(first, second) < 2e-13 and second < first + 1e-13


@pytest.mark.parametrize("base", [FREE, HEAVY], ids=["free", "heavy"])
@pytest.mark.parametrize("order", [2, 4, 8])
def test_splitting_is_time_reversible(base, order):
    """n = 1000 steps forward with h, then n with −h: back at the initial state to 1e-12."""
    scene = build_scene(scenario(**base, time={"end": 1.0}))
    model = scene.model
    y0 = initial_state(scene)
    y = y0.copy()
    out = np.empty((2, 8))
    status, _, steps = splitting_advance(y, np.array([0.0, 5.0]), out, 1, 1000, 10**6, model, order)
    assert status == 0 and steps == 1000 and np.max(np.abs(y - y0)) > 0.1  # it went somewhere
    status, _, steps = splitting_advance(y, np.array([5.0, 0.0]), out, 1, 1000, 10**6, model, order)
    assert status == 0 and steps == 1000
    assert np.max(np.abs(y - y0)) < 1e-12


def test_splitting_heavy_top_energy_bounded_and_vertical_momentum_exact():
    """Heavy asymmetric top, order 2, h = 0.005, 2·10^5 steps: L·up conserved to rounding, < 3e-13
    relative to |L₀| (every kick is horizontal in space and every rotation keeps R L: what is left is
    a random walk of ~1 ulp per operation, ~√(10^6) ε ≈ 1e-13); energy error < 1e-4 relative and its
    second-half max within 50 % of the first half's (the motion is chaotic: the oscillation is
    bounded, not periodic)."""
    traj = _run(HEAVY, {"end": 1000.0, "samples": 10_001}, method="splitting", order=2, step=0.005)
    assert np.max(np.abs(traj.invariants["L_vertical"])) < 3e-13
    first, second = _halves(traj.invariants["energy"])
    assert first < 1e-4 and second < 1.5 * first


def test_rkmk4_follows_time_dependent_torques(references):
    """Driven scene (harmonic body and space torques, damping, gravity): ω, Λ and the work W agree
    with dop853 to < 1e-7 at h = 1/80 and converge with order 4 (±0.2); |Λ| − 1 < 1e-14."""
    coarse, fine = (_run(DRIVEN, SPAN, method="rkmk4", step=1.0 / m) for m in (40, 80))
    e_coarse, e_fine = _error(coarse, references["driven"]), _error(fine, references["driven"])
    assert e_fine < 1e-7
    assert abs(math.log2(e_coarse / e_fine) - 4) < 0.2
    assert np.max(np.abs(fine.invariants["quaternion_norm"])) < 1e-14


def test_requires_refuses_scenes_out_of_reach():
    """splitting: no loads that do work (damping); dmv: torque-free only (gravity).  Requesting them
    anyway is an input error naming solver.method."""
    damped = build_scene(scenario(**FREE, loads=[{"type": "damping", "coefficient": 0.1}]))
    heavy = build_scene(scenario(**HEAVY))
    assert "conservative" in get_method("splitting").unsupported(damped)
    assert "torque-free" in get_method("dmv").unsupported(heavy)
    assert get_method("splitting").unsupported(heavy) is None
    assert get_method("rkmk4").unsupported(damped) is None
    with pytest.raises(InputError, match="solver.method"):
        _run(HEAVY, SPAN, method="dmv")
    with pytest.raises(InputError, match="solver.method"):
        _run({**FREE, "loads": [{"type": "damping", "coefficient": 0.1}]}, SPAN, method="splitting")


@pytest.mark.parametrize("method, order", [("splitting", 3), ("splitting", 10), ("dmv", 3), ("dmv", max(DMV_ORDERS) + 2)])
def test_unoffered_order_is_an_input_error(method, order):
    with pytest.raises(InputError, match="solver.order"):
        _run(FREE, SPAN, method=method, order=order, step=0.1)


MOMENTS = (1.0, 1.6, 2.2)


def test_dmv_modified_coefficients_are_symmetric_and_homogeneous_in_the_moments():
    """The modified moments cannot depend on how the axes are numbered: every coefficient is a
    symmetric function of (A, B, C) — equal for all 6 orderings up to the rounding of e1, e2, e3
    and of the cancelling terms of the polynomials in them (~1e-13 relative here; bound 1e-12).  Homogeneity:
    with I → λI at the same ω, h²N → λ² h²N and h²H → λ h²H while C_S is dimensionless and C_D
    scales as 1/I, so the s-coefficient of N^{j−l} H^l scales as λ^{l−2j} and the d-coefficient as
    λ^{l−2j−1}.  Entries beyond l = j, and rows beyond the highest degree, are zero."""
    table = modified_coefficients(MOMENTS)
    degrees = max(DMV_ORDERS) // 2 - 1
    assert table.shape[0] == 2 and table.shape[1] >= degrees and table.shape[2] >= degrees + 1
    for permutation in itertools.permutations(MOMENTS):
        np.testing.assert_allclose(modified_coefficients(permutation), table, rtol=1e-12, atol=0)
    scale = 1.7
    scaled = modified_coefficients([scale * x for x in MOMENTS])
    for j in range(1, degrees + 1):
        for l in range(j + 1):
            assert table[0, j - 1, l] != 0 and table[1, j - 1, l] != 0
            assert scaled[0, j - 1, l] == pytest.approx(table[0, j - 1, l] * scale ** (l - 2 * j), rel=1e-12)
            assert scaled[1, j - 1, l] == pytest.approx(table[1, j - 1, l] * scale ** (l - 2 * j - 1), rel=1e-12)
        assert not np.any(table[:, j - 1, j + 1 :])
    assert not np.any(table[:, degrees:, :])


def test_dmv_modified_coefficients_are_those_of_the_derivation():
    """tools/derive_dmv_moments.py (needs sympy, a development tool: skipped without it) derives the
    coefficients exactly; degrees 1–3 (order 8, a few seconds) agree with the table to 1e-12
    relative (the table's floating-point evaluation).  The higher degrees are checked by the measured convergence orders above."""
    pytest.importorskip("sympy")
    path = Path(__file__).resolve().parents[1] / "tools" / "derive_dmv_moments.py"
    spec = importlib.util.spec_from_file_location("derive_dmv_moments", path)
    derivation = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(derivation)
    sigma, delta = derivation.derive(8)
    alpha = [1 / Fraction(x).limit_denominator(1000) for x in MOMENTS]  # α_k = 1/I_k, exactly

    def value(coefficient):  # a Laurent polynomial in the α
        total = Fraction(0)
        for monomial, v in coefficient.terms():
            term = Fraction(int(v.numerator), int(v.denominator))
            for a, e in zip(alpha, monomial[3:]):
                term *= a**e
            total += term
        return float(total)

    table = modified_coefficients(MOMENTS)
    for j in (1, 2, 3):
        for l in range(j + 1):
            assert table[0, j - 1, l] == pytest.approx(value(sigma[j][l]), rel=1e-12)
            assert table[1, j - 1, l] == pytest.approx(value(delta[j][l]), rel=1e-12)


def test_dmv_rotation_solves_its_equations_to_rounding_against_a_50_digit_newton():
    """The DMV step's implicit equations c_k = (1 + |c|²) a_k + f_k c_i c_j are solved by Newton's
    method stopped at an update ≤ 1e-8 |c| (the next one would be ~1e-16 |c|).  Bound: the solution
    agrees with a 50-digit Newton solution (mpmath) to 2e-15 |c| (measured: 4.6e-16) over random bodies (moments over
    two decades, triangle inequality not required) and steps h|ω| from 1e-3 to 1 rad."""
    import mpmath
    from numba import njit

    from rotlab.core.dmv import dmv_rotation

    solve = njit(lambda h, m, j, f: dmv_rotation(h, m[0], m[1], m[2], j[0], j[1], j[2], f[0], f[1], f[2]))
    rng = np.random.default_rng(12)
    worst = 0.0
    for _ in range(300):
        moments = np.exp(rng.uniform(-2.3, 2.3, 3))
        m = rng.normal(size=3) * np.exp(rng.uniform(-3, 3))
        h = np.exp(rng.uniform(math.log(1e-3), 0.0)) / np.linalg.norm(m / moments)
        j = 1.0 / moments
        f = np.array([(moments[1] - moments[2]) * j[0], (moments[2] - moments[0]) * j[1], (moments[0] - moments[1]) * j[2]])
        c = np.array(solve(h, m, j, f)[:3])
        with mpmath.workdps(50):
            a = [mpmath.mpf(0.5) * mpmath.mpf(h) * mpmath.mpf(m[k]) * mpmath.mpf(j[k]) for k in range(3)]
            fm = [mpmath.mpf(x) for x in f]

            def residual(c1, c2, c3):
                alpha = 1 + c1 * c1 + c2 * c2 + c3 * c3
                return [c1 - alpha * a[0] - fm[0] * c2 * c3, c2 - alpha * a[1] - fm[1] * c3 * c1, c3 - alpha * a[2] - fm[2] * c1 * c2]

            exact = mpmath.findroot(residual, [mpmath.mpf(x) for x in c])
        reference = np.array([float(x) for x in exact])
        worst = max(worst, float(np.max(np.abs(c - reference)) / np.max(np.abs(reference))))
    assert worst <= 2e-15, worst


def test_dmv_step_without_a_solution_stops_there_and_keeps_the_valid_samples():
    """At h|ω| = 1.96 (under dmv's limit of 2) this body's DMV equations have no solution near the
    identity at the fifth step: Newton does not converge, the state turns non-finite and the run
    stops, saying between which samples; the 5 samples before stay, finite, with the energy and
    |L| the DMV map conserves (to 1e-13: rounding over 4 steps).  (So close to the limit the step
    at which the solution disappears depends on the last bits of m = I ω.)"""
    traj = rotlab.simulate(scenario(
        body={"principal_moments": [0.92, 0.2564, 2.5557], "allow_triangle_violation": True},
        initial={"omega": [3.323, 0.2258, -0.3526]},
        time={"end": 11.7, "samples": 21}, solver={"method": "dmv", "order": 2, "step": 0.585}), check=False)
    assert traj.stats.failure.startswith("state became non-finite between t = 2.34 s and t = 2.925 s")
    assert traj.t.shape == (5,) and np.all(np.isfinite(traj.quaternion)) and np.all(np.isfinite(traj.omega))
    moments = np.array([0.92, 0.2564, 2.5557])
    energy = np.sum(moments * traj.omega**2, axis=1)
    momentum = np.sum((moments * traj.omega) ** 2, axis=1)
    assert np.max(np.abs(energy / energy[0] - 1.0)) < 1e-13 and np.max(np.abs(momentum / momentum[0] - 1.0)) < 1e-13
