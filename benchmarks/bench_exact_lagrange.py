"""Timing of the closed-form heavy symmetric top (rotlab.core.exact.lagrange).

Prints, per scenario, the set-up time (one sample) and the time for 10^6 samples spread over
±1000 nutation periods (best of --repeat runs).  Run: python benchmarks/bench_exact_lagrange.py
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # run from a checkout without installing

from rotlab.core import quaternion as quat  # noqa: E402
from rotlab.core.exact.lagrange import lagrange_top_solution  # noqa: E402

Q0 = quat.from_euler_313(0.2, 0.8, 0.3)


def _near_vertical_omega(r: float = 2.0, a_over_c: float = 1.0 / 1.5) -> np.ndarray:
    """b − a ~ rounding: the axis passes within ~1e-16 of the upward vertical every period."""
    g1, g2, u0 = quat.to_matrix(Q0)[2]
    along = r / a_over_c * (1 - u0) / (g1 * g1 + g2 * g2)
    return np.array([along * g1 + 0.3 * g2, along * g2 - 0.3 * g1, r])


def _regular_omega(theta=0.8, phi=0.3, psi_dot=1.3, mgl=0.7, A=1.0, C=1.5) -> np.ndarray:
    r = A * (math.cos(theta) * psi_dot**2 + mgl / A) / psi_dot / C
    return np.array([psi_dot * math.sin(theta) * math.sin(phi), psi_dot * math.sin(theta) * math.cos(phi), r])


SCENARIOS = {  # name: (A, C, mgl, omega0, q0)
    "standing top": (1.0, 1.5, 0.7, np.array([0.4, -0.9, 2.1]), Q0),
    "hanging top": (1.2, 0.6, -1.1, np.array([1.3, 0.2, -0.7]), Q0),
    "fast top (r = 200)": (1.0, 1.5, 0.7, np.array([0.05, -0.03, 200.0]), Q0),
    "torque-free (m = 0)": (1.0, 1.5, 0.0, np.array([0.5, -0.3, 1.2]), Q0),
    "axis through vertical": (1.0, 1.5, 0.7, _near_vertical_omega(), Q0),
    "regular precession": (1.0, 1.5, 0.7, _regular_omega(), quat.from_euler_313(0.2, 0.8, 0.3)),
}


def _best(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=10**6)
    parser.add_argument("--repeat", type=int, default=2)
    args = parser.parse_args()
    print(f"{'scenario':<24}{'set-up [ms]':>12}{f'{args.samples:.0e} samples [s]':>20}{'ns/sample':>11}")
    for name, (A, C, mgl, omega0, q0) in SCENARIOS.items():
        one = np.array([1.0])
        setup = _best(lambda: lagrange_top_solution(A, C, mgl, omega0, q0, 0.0, one), 5 * args.repeat)
        q, _ = lagrange_top_solution(A, C, mgl, omega0, q0, 0.0, np.linspace(0.0, 50.0, 2001))
        period = 50.0 / max(1, np.count_nonzero(np.diff(np.sign(np.diff(quat.to_matrix(q)[:, 2, 2]))) < 0))
        t = np.linspace(-1000 * period, 1000 * period, args.samples)
        total = _best(lambda: lagrange_top_solution(A, C, mgl, omega0, q0, 0.0, t), args.repeat)
        print(f"{name:<24}{1e3 * setup:>12.2f}{total:>20.3f}{1e9 * total / args.samples:>11.0f}")


if __name__ == "__main__":
    main()
