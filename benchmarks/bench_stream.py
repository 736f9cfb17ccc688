"""Streamed `rotlab run`: peak memory, wall time, size and write rate against the run's length,
and what each entity costs per sample.

    python benchmarks/bench_stream.py            # 10⁵, 10⁶, 10⁷ samples of every shipped config
    python benchmarks/bench_stream.py --full     # and 10⁸ (general.toml)
    python benchmarks/bench_stream.py --entities # bytes per entity per sample only
    python benchmarks/bench_stream.py --cold     # every run on an empty numba cache (a first run)

Every run is the installed CLI in a child process (`rotlab run CONFIG --duration D -o FILE`);
peak memory is the child's maximum resident set (``os.wait4``), "before the first sample" the
same command for a 2-second run (imports, compiled kernels, Rerun's threads).  The write rate is
samples / the writing time the run reports (conversion + encoding + file, interleaved with the
integration).
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
import uuid
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CONFIGS = ("euler.toml", "dzhanibekov.toml", "lagrange.toml", "general.toml")
ROTLAB = [sys.executable, "-m", "rotlab"]


def run_child(config: Path, duration: float, out: Path, cold: bool = False) -> dict:
    """One `rotlab run` in a child process: wall s, peak RSS MB, writing s, file MB.  ``cold``:
    with empty numba and formula caches, as a first run after installing."""
    with tempfile.TemporaryDirectory() as caches:
        env = dict(os.environ, NUMBA_CACHE_DIR=f"{caches}/numba", ROTLAB_CACHE=f"{caches}/rotlab") if cold else None
        return _run_child(config, duration, out, env)


def _run_child(config: Path, duration: float, out: Path, env: dict | None) -> dict:
    started = time.perf_counter()
    proc = subprocess.Popen([*ROTLAB, "run", str(config.resolve()), "--duration", repr(duration), "-o", str(out.resolve()), "--max-megabytes", "1e9"],
                            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, env=env,
                            cwd=out.resolve().parent)  # outside the checkout: ``-m`` puts the cwd ahead of PYTHONPATH
    text = proc.stdout.read()
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - started
    if status != 0:
        raise SystemExit(f"rotlab run {config.name} --duration {duration} failed (status {status})")
    writing = re.search(r"writing ([0-9.e+]+) s", text)
    samples = re.search(r"run +([0-9,]+) samples", text)
    size = out.stat().st_size
    out.unlink()
    return {"wall": wall, "peak": usage.ru_maxrss / 1024, "writing": float(writing.group(1)) if writing else float("nan"),
            "samples": int(samples.group(1).replace(",", "")), "bytes": size}


def lengths(full: bool) -> list[int]:
    return [10**5, 10**6, 10**7] + ([10**8] if full else [])


def memory_table(full: bool, cold: bool) -> None:
    """Run before anything large is imported: Linux keeps a parent's resident high-water mark in
    a forked and exec'ed child's ``ru_maxrss``, so the parent must stay small."""
    import tomllib

    print("| config | samples | wall (s) | writing (s) | write rate (M samples/s) | file (MB) | B/sample | peak RSS (MB) |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "bench.rrd"
        for name in CONFIGS:
            config = ROOT / "configs" / name
            rate = tomllib.loads(config.read_text(encoding="utf-8")).get("time", {}).get("sample_rate", 100.0)
            base = run_child(config, 2.0, out, cold)
            print(f"| {name} | before the first sample (2 s run) | {base['wall']:.2f} | | | | | {base['peak']:.0f} |", flush=True)
            for n in lengths(full and name == "general.toml"):
                r = run_child(config, (n - 1) / rate, out, cold)
                print(f"| {name} | {r['samples']:,} | {r['wall']:.1f} | {r['writing']:.2f} | {r['samples'] / r['writing'] / 1e6:.2f} | "
                      f"{r['bytes'] / 1e6:,.1f} | {r['bytes'] / r['samples']:.0f} | {r['peak']:.0f} |", flush=True)


def entity_table(samples: int = 200_000) -> None:
    """Bytes per sample of each entity alone, encoded as `rotlab run` writes it (send_columns,
    16,384 rows per call, LZ4): the full-rate ones at every sample, the visual ones per kept sample."""
    import rerun as rr

    import rotlab
    from rotlab.recording import layout, visuals, writer

    print("| config | entity | rate | columns | B per sample written |")
    print("|---|---|---|---:|---:|")
    for name in ("euler.toml", "general.toml"):
        config = rotlab.load(ROOT / "configs" / name)
        rate = config.time.sample_rate or 100.0
        traj = rotlab.simulate(rotlab.load(ROOT / "configs" / name, duration=(samples - 1) / rate))
        views = writer._views(traj)
        ns = writer._nanoseconds(traj.t)

        def encoded(send) -> int:
            rec = rr.RecordingStream("bench", recording_id=uuid.uuid4())
            rec.set_log_time_enabled(False)
            stream = rr.binary_stream(rec)
            for rows in writer._slices(len(ns), writer.CHUNK_ROWS):
                send(rec, [rr.TimeColumn(layout.TIMELINE, duration=ns[rows])], rows)
            return len(stream.read(flush=True))

        empty = encoded(lambda rec, index, rows: None)
        entries = [(entity, values, "Scalars") for entity, (values, _) in views.series.items()]
        entries += [(layout.BODY, visuals.xyzw(views.unit_q), "Transform3D"), (layout.AXIS_TIP, views.geometry.axis_tips, "Points3D"),
                    (layout.OMEGA_ARROW, views.omega_space, "Arrows3D"), (layout.L_ARROW, traj.L_space, "Arrows3D")]
        for entity, values, kind in entries:
            column = {"Scalars": lambda v: rr.Scalars.columns(scalars=v), "Transform3D": lambda v: rr.Transform3D.columns(quaternion=v),
                      "Points3D": lambda v: rr.Points3D.columns(positions=v), "Arrows3D": lambda v: rr.Arrows3D.columns(vectors=v)}[kind]
            size = encoded(lambda rec, index, rows: rec.send_columns(entity, index, column(values[rows]))) - empty
            full = writer.full_rate(entity)
            print(f"| {name} | `{entity}` | {'every sample' if full else 'visual'} | {values.shape[1] if values.ndim > 1 else 1} | "
                  f"{size / len(ns):.1f} |", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--full", action="store_true", help="also 10⁸ samples of general.toml (~10 GB of disk, minutes)")
    parser.add_argument("--entities", action="store_true", help="only the bytes per entity")
    parser.add_argument("--cold", action="store_true", help="every run with empty numba and formula caches (a first run)")
    args = parser.parse_args()
    if not args.entities:
        memory_table(args.full, args.cold)  # first: see its docstring
        print()
    entity_table()


if __name__ == "__main__":
    main()
