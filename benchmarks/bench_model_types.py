"""What an empty load group would cost a step: the model of a damped free body (damping alone,
as ``rotlab.scene.loads.build_model`` makes it) against the same model with empty force, term
and table groups added (the numba type a kernel would share with more scenes, compiling fewer
specialisations).  rk4, h = 1e-3 s, 20,000 steps, integration only; medians of the repeats.

    python benchmarks/bench_model_types.py [--repeats 9]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from rotlab.core.dynamics import euler_coefficients
from rotlab.core.model import Model
from rotlab.core.rk4 import rk4_advance
from rotlab.core.state import STATE_SIZE
from rotlab.core.torques import F_COLUMNS, T_COLUMNS, TB_COLUMNS

EMPTY = {"forces": {"forces": np.zeros((0, F_COLUMNS))}, "terms": {"terms": np.zeros((0, T_COLUMNS))},
         "tables": {"tables": np.zeros((0, TB_COLUMNS)), "table_t": np.zeros(0), "table_v": np.zeros((0, 3))}}
SUBSTEPS = 50  # rk4 steps a sample interval: h = 1e-3 s on the 0.05 s grid below
VARIANTS = {"damping alone": (), "+ empty forces": ("forces",), "+ empty terms": ("terms",), "+ empty tables": ("tables",),
            "+ all three empty": ("forces", "terms", "tables")}


def model_of(empty: tuple[str, ...]) -> Model:
    fields = dict(euler=euler_coefficients(np.array([2.0, 3.0, 4.0])), breaks=np.zeros(0), forces=None, terms=None, tables=None,
                  table_t=None, table_v=None, damping=0.1, expressions=None, user=None)
    for group in empty:
        fields.update(EMPTY[group])
    return Model(**fields)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=9)
    args = parser.parse_args()
    times = np.linspace(0.0, 20.0, 401)
    steps = (times.shape[0] - 1) * SUBSTEPS
    y0 = np.array([1.0, 0.0, 0.0, 0.0, 0.3, -1.1, 0.7, 0.0])
    print(f"{'model':22s} {'rk4 ns/step':>12s} {'ratio':>7s}  states the first row's bit for bit")
    base = None
    for name, empty in VARIANTS.items():
        model, out, spent = model_of(empty), np.zeros((times.shape[0], STATE_SIZE)), []
        for _ in range(args.repeats + 1):  # the first call compiles or loads the kernel
            y = y0.copy()
            start = time.perf_counter()
            rk4_advance(y, times, out, 1, SUBSTEPS, 10**9, model)
            spent.append(time.perf_counter() - start)
        ns = float(np.median(spent[1:])) / steps * 1e9
        if base is None:
            base = (ns, out.copy())
        same = np.array_equal(out[1:], base[1][1:])
        print(f"{name:22s} {ns:12.1f} {ns / base[0]:6.2f}x  {'yes' if same else 'NO'}")


if __name__ == "__main__":
    main()
