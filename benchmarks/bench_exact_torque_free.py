"""Time rotlab.core.exact.torque_free.torque_free_solution on 10^6 samples (prints a table, asserts nothing).

Run from the repository root:  python -m benchmarks.bench_exact_torque_free
"""

from __future__ import annotations

import time

import numpy as np

from rotlab.core.exact.torque_free import torque_free_solution

CASES = {
    "asymmetric, L² > 2T·B  (ellipj path)": ((1.0, 2.0, 3.0), (1.0, 0.3, 0.2)),
    "asymmetric, L² < 2T·B  (lattice path)": ((3.0, 1.0, 2.0), (0.2, 0.5, 1.0)),
    "asymmetric, 1e-6 from separatrix": ((1.0, 2.0, 3.0), (np.sqrt(3.0 * (1 + 1e-6)) * 0.2, 0.9, 0.2)),
    "asymmetric, on separatrix": ((2.0, 3.0, 6.0), (0.75, 0.7, 0.25)),
    "axisymmetric": ((1.0, 1.0, 3.0), (0.3, 0.5, 0.7)),
}


def main(n: int = 10**6, repeat: int = 3) -> None:
    t = np.random.default_rng(0).uniform(-1e3, 1e3, n)
    q0 = np.array([0.9, 0.1, -0.3, 0.3]) / np.linalg.norm([0.9, 0.1, -0.3, 0.3])
    print(f"{'case':<42} {'best of ' + str(repeat) + ' [s]':>14} {'ns/sample':>10}")
    for name, (moments, omega0) in CASES.items():
        torque_free_solution(moments, omega0, q0, 0.0, t[:10])  # warm-up
        best = min(_timed(moments, omega0, q0, t) for _ in range(repeat))
        print(f"{name:<42} {best:>14.3f} {1e9 * best / n:>10.0f}")


def _timed(moments, omega0, q0, t) -> float:
    start = time.perf_counter()
    torque_free_solution(moments, omega0, q0, 0.0, t)
    return time.perf_counter() - start


if __name__ == "__main__":
    main()
