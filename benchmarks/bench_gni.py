"""GNI free body (I = (2, 1, 2/3), m0 = (cos 1.1, 0, sin 1.1), t ≤ 100): work-precision of every
rotlab method against scipy solve_ivp and the seeds' RK4, the speed-up at max error ≤ 1e-10, and
the energy error of the splitting methods over 10^7 steps (max after every step, per tenth of the
run).  A thin wrapper over ``rotlab.bench`` (the same code as ``rotlab bench --problem gni``).

    python benchmarks/bench_gni.py [--repeats 5] [--steps 10000000] [--json gni.json] [--plots DIR]
"""

from __future__ import annotations

import argparse
from pathlib import Path

from rotlab.bench import report, runner
from rotlab.bench.problems import get_problems


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--steps", type=int, default=10_000_000, help="steps of the long energy run (0: skip it)")
    parser.add_argument("--step", type=float, default=0.05, help="step of the long energy run")
    parser.add_argument("--json", type=Path, default=None)
    parser.add_argument("--plots", type=Path, default=None)
    args = parser.parse_args()

    options = runner.Options.make(quick=False, repeats=args.repeats, log=lambda line: print(line, flush=True))
    (problem,) = get_problems(["gni"])
    runner.warm_up_peers()
    records, ref = runner.run_problem(problem, options)
    print(report.work_precision_table(records, problem.name, problem.title, ref.how))
    print()
    rows = runner.ratios(records, runner.THRESHOLD)
    print(report.ratio_table(rows))
    extra = list(rows)
    if args.steps:
        print()
        energy = runner.energy_windows(options, steps=args.steps, h=args.step)
        print(report.energy_table(energy))
        extra += energy
    if args.json:
        report.write_json(args.json, records, extra)
    if args.plots:
        for path in report.write_plots(args.plots, records, {problem.name: problem.title}):
            print(f"wrote {path}")


if __name__ == "__main__":
    main()
