"""rotlab's command line.  Heavy modules (numpy, numba, rerun) are imported inside the
commands that need them, so ``rotlab --help`` stays fast."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated, Optional

import typer

from rotlab import __version__
from rotlab.bench.command import bench

app = typer.Typer(
    name="rotlab",
    help="A laboratory for the rotation of a rigid body about a fixed point.",
    add_completion=False,
    no_args_is_help=True,
    pretty_exceptions_enable=False,
)

TEMPLATE_KINDS = ("euler", "lagrange", "general")


def _fail(exc: Exception) -> None:
    """Print one line to stderr and exit with the error's code (2 bad input, 1 run failure)."""
    typer.echo(f"rotlab: error: {exc}", err=True)
    raise typer.Exit(getattr(exc, "exit_code", 1))


def _check_outdir(outdir: Path) -> None:
    from rotlab.errors import InputError

    if outdir.exists() and not outdir.is_dir():
        raise InputError(f"--outdir {outdir}", "is a file: give a directory")


def _version(value: bool) -> None:
    if value:
        typer.echo(f"rotlab {__version__}")
        raise typer.Exit()


@app.callback()
def main_options(
    version: Annotated[bool, typer.Option("--version", callback=_version, is_eager=True, help="Show the version and exit.")] = False,
) -> None:
    """A laboratory for the rotation of a rigid body about a fixed point."""


@app.command()
def run(
    config: Annotated[Path, typer.Argument(help="Scenario TOML file.")],
    output: Annotated[Optional[Path], typer.Option("-o", "--output", help="Recording to write (default: <config name>.rrd).")] = None,
    method: Annotated[Optional[str], typer.Option("--method", help="Override solver.method (auto, rk4, dop853).")] = None,
    duration: Annotated[Optional[float], typer.Option("--duration", help="Override the span: end = start + DURATION seconds.")] = None,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No summary, no progress bar.")] = False,
) -> None:
    """Simulate a scenario and write a Rerun recording (.rrd)."""
    from rotlab.errors import InputError, RunFailure

    try:
        _run(config, output, method, duration, quiet)
    except (InputError, RunFailure) as exc:
        _fail(exc)


def _run(config: Path, output: Path | None, method: str | None, duration: float | None, quiet: bool) -> None:
    import time

    from rotlab import api
    from rotlab.errors import InputError, Interrupted, RunFailure
    from rotlab.progress import ProgressBar
    from rotlab.recording.writer import check_output_path, partial_path, write_recording
    from rotlab.scene.scene import build_scene
    from rotlab.summary import summary_lines

    started = time.perf_counter()
    if duration is not None and not (duration > 0 and duration < float("inf")):
        raise InputError("--duration", f"must be a positive number of seconds (got {duration})")
    scenario = api.load(config, method=method, duration=duration)
    target = output or Path(scenario.output.path or f"{config.stem}.rrd")
    check_output_path(target)
    scene = build_scene(scenario)
    bar = None if quiet else ProgressBar(f"{config.name}")
    try:
        traj = api.run_scene(scene, progress=bar)
    finally:
        if bar is not None:
            bar.close()
    if traj.stats.failure:  # an incomplete run never replaces a complete recording
        target = partial_path(target)
    write_recording(traj, target)
    if not quiet:
        for line in summary_lines(traj, config, target, time.perf_counter() - started):
            typer.echo(line)
    if traj.stats.failure:
        stopped = Interrupted if traj.stats.interrupted else RunFailure
        raise stopped(f"{config}: run stopped: {traj.stats.failure}; the {traj.t.shape[0]:,} valid samples are in {target}")


@app.command()
def validate(configs: Annotated[list[Path], typer.Argument(help="Scenario TOML files.")]) -> None:
    """Check scenario files without running them (one line per file)."""
    from rotlab.config import load_scenario
    from rotlab.errors import InputError

    failed = 0
    for path in configs:
        try:
            scenario = load_scenario(path)
            typer.echo(f"{path}: ok ({scenario.time.sample_count:,} samples, method {scenario.solver.method})")
        except InputError as exc:
            failed += 1
            typer.echo(f"rotlab: error: {exc}", err=True)
    if failed:
        raise typer.Exit(2)


@app.command()
def batch(
    paths: Annotated[list[Path], typer.Argument(help="Scenario files and/or directories of *.toml files.")],
    outdir: Annotated[Path, typer.Option("-o", "--outdir", help="Where recordings, summary.json and junit.xml go.")] = Path("batch-out"),
    jobs: Annotated[int, typer.Option("-j", "--jobs", min=1, help="Parallel processes.")] = 2,
) -> None:
    """Run scenario suites in parallel; exit 1 if any scenario errs or breaks a [checks] bound."""
    from rotlab.batch.reports import table, write_junit, write_summary
    from rotlab.batch.runner import collect_configs, run_batch
    from rotlab.errors import InputError

    try:
        configs = collect_configs(paths)
        _check_outdir(outdir)
    except InputError as exc:
        _fail(exc)
    results = run_batch(configs, outdir, jobs)
    write_summary(results, outdir / "summary.json")
    write_junit(results, outdir / "junit.xml")
    typer.echo(table(results))
    if any(r.status != "pass" for r in results):
        raise typer.Exit(1)


@app.command()
def sweep(
    config: Annotated[Path, typer.Argument(help="Scenario TOML file with a [sweep] section.")],
    outdir: Annotated[Path, typer.Option("-o", "--outdir", help="Where results.csv/.parquet and the comparison recording go.")] = Path("sweep-out"),
    jobs: Annotated[int, typer.Option("-j", "--jobs", min=1, help="Local processes.")] = 2,
    dask: Annotated[Optional[str], typer.Option("--dask", help="Run on an existing Dask cluster: tcp://HOST:PORT.")] = None,
) -> None:
    """Run a parameter sweep; exit 1 if any case errs or breaks a [checks] bound."""
    from rotlab.errors import InputError
    from rotlab.sweep.report import terminal_table, write_comparison, write_results
    from rotlab.sweep.runner import plan, run_sweep

    try:
        _check_outdir(outdir)
        sweep_plan = plan(config)
        outdir.mkdir(parents=True, exist_ok=True)
        outcomes, how = run_sweep(sweep_plan, jobs=jobs, dask_address=dask)
    except InputError as exc:
        _fail(exc)
    write_results(outcomes, outdir)
    write_comparison(outcomes, outdir / f"{config.stem}_sweep.rrd", sweep_plan.base.title)
    typer.echo(terminal_table(outcomes, how))
    typer.echo(f"wrote {outdir / 'results.csv'}, {outdir / 'results.parquet'}, {outdir / (config.stem + '_sweep.rrd')}")
    if any(o.status != "pass" for o in outcomes):
        raise typer.Exit(1)


@app.command()
def snapshot(
    recording: Annotated[Path, typer.Argument(help="A recording written by `rotlab run`.")],
    output: Annotated[Path, typer.Option("-o", "--output", help="PNG file to write.")] = Path("snapshot.png"),
    at: Annotated[Optional[float], typer.Option("--time", help="Simulation time in s (default: the end).")] = None,
    size: Annotated[str, typer.Option("--size", help="Window size WIDTHxHEIGHT.")] = "1600x900",
) -> None:
    """Render the Rerun viewer headless at a given time to a PNG (for reports)."""
    from rotlab.errors import InputError, RunFailure
    from rotlab.recording.snapshot import parse_size
    from rotlab.recording.snapshot import snapshot as render

    try:
        path = render(recording, output, at, parse_size(size))
    except (InputError, RunFailure) as exc:
        _fail(exc)
    typer.echo(f"wrote {path}")


@app.command()
def stress(quick: Annotated[bool, typer.Option("--quick", help="The subset that runs in under two minutes.")] = False) -> None:
    """Run the stress suite of hard scenes; exit 0 only if every check passes."""
    from rotlab.stress.suite import run_suite

    def report(outcome) -> None:
        verdict = "PASS" if outcome.passed else "FAIL"
        typer.echo(f"{verdict}  {outcome.name:44} {outcome.figure}  [bound {outcome.bound}; {outcome.seconds:.1f} s]")

    outcomes = run_suite(quick, report)
    passed = sum(o.passed for o in outcomes)
    typer.echo(f"stress: {passed} of {len(outcomes)} checks passed")
    if passed < len(outcomes):
        raise typer.Exit(1)


app.command(name="bench")(bench)


@app.command()
def new(kind: Annotated[str, typer.Argument(help="euler, lagrange or general.")]) -> None:
    """Print a commented scenario template: `rotlab new lagrange > my_top.toml`."""
    from importlib.resources import files

    if kind not in TEMPLATE_KINDS:
        typer.echo(f"rotlab: error: KIND: unknown kind '{kind}': choose one of {', '.join(TEMPLATE_KINDS)}", err=True)
        raise typer.Exit(2)
    typer.echo(files("rotlab").joinpath("templates", f"{kind}.toml").read_text(encoding="utf-8"), nl=False)


def main() -> None:
    """Console entry point."""
    try:
        app()
    except KeyboardInterrupt:
        typer.echo("rotlab: interrupted", err=True)
        sys.exit(130)


if __name__ == "__main__":
    main()
