"""rotlab's command line.  Heavy modules (numpy, numba, rerun) are imported inside the
commands that need them, so ``rotlab --help`` stays fast."""

from __future__ import annotations

import signal
import sys
from pathlib import Path
from typing import Annotated, Literal, Optional

import typer

try:  # recent typer carries its own copy of click; earlier releases use the click package
    from typer._click import exceptions as click_errors
except ImportError:  # pragma: no cover
    from click import exceptions as click_errors  # type: ignore[no-redef]

from rotlab import __version__, interrupts
from rotlab.bench.command import bench
from rotlab.method_names import METHOD_NAMES

app = typer.Typer(
    name="rotlab",
    help="A laboratory for the rotation of a rigid body about a fixed point.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,  # help is plain text: "[checks]" and "[sweep]" are TOML tables, not markup
)

TEMPLATE_KINDS = ("euler", "lagrange", "general", "box", "satellite")
DEFAULT_VIEWER_URL = "rerun+http://127.0.0.1:9876/proxy"
TemplateKind = Literal[TEMPLATE_KINDS]  # type: ignore[valid-type]
MethodName = Literal[METHOD_NAMES]  # type: ignore[valid-type]
SetOption = Annotated[
    Optional[list[str]],
    typer.Option("--set", metavar="KEY=VALUE", help="Override a scenario key, validated like the file: --set initial.omega=[0,0,50] (repeatable)."),
]
_reported = False  # an error line was already printed (main() adds none)


def _hint(scenario, where: str = "") -> None:
    """Print the scenario's unit-slip hints (``rotlab.config.hints``) to stderr: the run goes on."""
    from rotlab.config.hints import hints

    for line in hints(scenario):
        typer.echo(f"rotlab: hint: {where}{line}", err=True)


def _fail(exc: Exception) -> None:
    """Print one line to stderr and exit with the error's code (2 bad input, 1 run failure,
    130 interrupted)."""
    from rotlab.errors import Interrupted

    global _reported
    typer.echo(f"rotlab: {'interrupted' if isinstance(exc, Interrupted) else 'error'}: {exc}", err=True)
    _reported = True
    raise typer.Exit(getattr(exc, "exit_code", 1))


def _overrides(assignments: list[str] | None) -> dict[str, object]:
    """``--set KEY=VALUE`` options → {key path: value} (values are TOML values)."""
    from rotlab.config.paths import parse_assignment

    return dict(parse_assignment(text) for text in assignments or ())


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
    output: Annotated[Optional[Path], typer.Option("-o", "--output", help="Recording to write (default: <config name>.rrd; none with a live viewer unless given).")] = None,
    method: Annotated[Optional[MethodName], typer.Option("--method", help="Override solver.method.")] = None,
    duration: Annotated[Optional[float], typer.Option("--duration", help="Override the span: end = start + DURATION seconds.")] = None,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No summary, no progress bar.")] = False,
    assignments: SetOption = None,
    spawn: Annotated[bool, typer.Option("--spawn", help="Start a Rerun viewer and stream the run into it as it is computed.")] = False,
    connect: Annotated[bool, typer.Option("--connect", help="Stream to a running viewer (at --url).")] = False,
    url: Annotated[Optional[str], typer.Option("--url", help=f"The viewer's gRPC URL for --connect (default {DEFAULT_VIEWER_URL}).")] = None,
    serve_web: Annotated[bool, typer.Option("--serve-web", help="Serve the web viewer (http://127.0.0.1:9090) and stream into it; after the run it serves until Ctrl-C (a Ctrl-C during the run stops both).")] = False,
    port: Annotated[int, typer.Option("--port", min=1, max=65535, help="gRPC port of the viewer started by --spawn or the server of --serve-web.")] = 9876,
    web_port: Annotated[int, typer.Option("--web-port", min=1, max=65535, help="HTTP port of --serve-web.")] = 9090,
    bind: Annotated[str, typer.Option("--bind", help="Address --serve-web's servers (the web viewer and the run's data) listen on. The default, 127.0.0.1, is this machine only; 0.0.0.0 EXPOSES THE RUN to every machine that can reach this one.")] = "127.0.0.1",
    timeout: Annotated[Optional[float], typer.Option("--timeout", help="Stop the run after SECONDS of wall-clock time (the samples so far are kept).")] = None,
    max_megabytes: Annotated[Optional[float], typer.Option("--max-megabytes", help="Override [output] max_megabytes: the largest recording to start without asking.")] = None,
) -> None:
    """Simulate a scenario and write a Rerun recording (.rrd), or stream it to a viewer."""
    from rotlab.errors import InputError, Interrupted, RunFailure

    try:
        _run(config, output, method, duration, quiet, _overrides(assignments), spawn,
             (url or DEFAULT_VIEWER_URL) if (connect or url) else None, serve_web, timeout, max_megabytes, port, web_port, bind)
    except KeyboardInterrupt:  # before the run began, or a second Ctrl-C: nothing was kept
        _fail(Interrupted("interrupted before any sample was kept"))
    except (InputError, RunFailure) as exc:
        _fail(exc)


def _positive(name: str, value: float | None) -> None:
    from rotlab.errors import InputError

    if value is not None and not (value > 0 and value < float("inf")):
        raise InputError(name, f"must be a positive number (got {value})")


def _serve_until_interrupted(url: str | None) -> None:
    """Keep the web viewer's server up (it holds the recording) until Ctrl-C."""
    import time

    try:  # (the line inside: a Ctrl-C that follows it at once is the one it asks for, not an interrupted run)
        typer.echo(f"rotlab: serving the web viewer at {url} — Ctrl-C to stop (the file is finished then)", err=True)
        while True:
            time.sleep(0.5)
    except KeyboardInterrupt:
        pass


def _run(config: Path, output: Path | None, method: str | None, duration: float | None, quiet: bool, overrides: dict[str, object],
         spawn: bool = False, connect: str | None = None, serve_web: bool = False, timeout: float | None = None,
         max_megabytes: float | None = None, port: int = 9876, web_port: int = 9090, bind: str = "127.0.0.1") -> None:
    import time

    with interrupts.deferred():  # Ctrl-C while numpy, scipy, numba and rerun load: raised after, not inside them
        from rotlab.withheld import withhold_pandas, withhold_scipy_linalg
        withhold_scipy_linalg()  # numba would import SciPy's linear algebra to ask about BLAS for functions we never call
        from rotlab import api
        from rotlab.errors import InputError, Interrupted, RunFailure, valid_samples
        from rotlab.progress import StreamProgress
        from rotlab.recording.sink import LOOPBACK, LiveOptions, RecordingSink
        from rotlab.recording.writer import check_output_path, check_size, partial_path
        from rotlab.scene.scene import build_scene
        from rotlab.summary import summary_lines
        withhold_pandas()  # pyarrow would import pandas (time and memory) just to ask if our arrays are Series
    interrupts.shield_numba_compilation()

    started = time.perf_counter()
    _positive("--duration", duration)
    _positive("--timeout", timeout)
    _positive("--max-megabytes", max_megabytes)
    live = LiveOptions(spawn=spawn, connect=connect, serve_web=serve_web, grpc_port=port, web_port=web_port, bind=bind)
    if serve_web:
        live.check_bind()
        if bind != LOOPBACK:
            typer.echo(f"rotlab: --bind {bind}: the run's data server is open to every machine that can reach this one", err=True)
    scenario = api.load(config, method=method, duration=duration, overrides=overrides)
    _hint(scenario)
    target = output if output is not None or live.any else Path(scenario.output.path or f"{config.stem}.rrd")
    if target is not None:
        check_output_path(target, inputs=(config,))
        if target.suffix.lower() != ".rrd":
            raise InputError(f"output {target}", "a recording is a Rerun .rrd file: give a name ending in .rrd "
                                                 "(for a picture of it: rotlab snapshot RUN.rrd -o FIG.png)")
        check_output_path(partial_path(target), inputs=(config,))
        check_size(scenario, max_megabytes or scenario.output.max_megabytes)
    scene = build_scene(scenario)
    bar = None if quiet else StreamProgress(config.name)
    sink = RecordingSink(target, live)
    if sink.unreached is not None:
        if target is None:
            sink.abort()
            raise RunFailure(f"{sink.unreached}, and no -o FILE was given: nothing was run (add -o run.rrd to keep the run in a file)")
        typer.echo(f"rotlab: {sink.unreached}: the run goes to {target} only", err=True)
    serve = (lambda: _serve_until_interrupted(sink.web_url)) if sink.live.serve_web else None  # the server lives as long as the stream
    run, writing, final = api.record(scene, sink, progress=bar, timeout=timeout, before_close=serve)
    if sink.live_problem is not None:
        typer.echo(f"rotlab: {sink.live_problem}" + ("; the file has every sample" if target is not None else ""), err=True)
    if not quiet:
        where = sink.web_url or ("viewer spawned" if sink.live.spawn else sink.live.connect)
        if where and sink.live_problem is not None:
            where += " (given up during the run)"
        for line in summary_lines(run, config, final, time.perf_counter() - started, writing, where):
            typer.echo(line)
    if run.stats.failure:
        stopped = Interrupted if run.stats.interrupted else RunFailure
        kept = f"; {valid_samples(run.samples, final)}" if final is not None else "; no sample was kept" if run.samples == 0 else ""
        raise stopped(f"{config}: run stopped: {run.stats.failure}{kept}")


@app.command()
def validate(
    paths: Annotated[list[Path], typer.Argument(help="Scenario files and/or directories of *.toml files.")],
    assignments: SetOption = None,
) -> None:
    """Check scenario files without running them (one line per file)."""
    from rotlab.batch.runner import collect_configs
    from rotlab.config.loader import parse_scenario, read_toml
    from rotlab.errors import InputError
    from rotlab.geometry_inertia import describe

    try:
        configs = collect_configs(paths)
        overrides = _overrides(assignments)
    except InputError as exc:
        _fail(exc)
    failed = 0
    for path in configs:
        try:
            raw = read_toml(path)
            scenario = parse_scenario(raw, source=str(path), overrides=overrides)
            if scenario.sweep is not None and overrides:  # (`rotlab sweep` takes no --set: its checks on the values given)
                from rotlab.sweep.cases import check_parameters

                check_parameters(scenario, str(path))
            elif scenario.sweep is not None:  # what `rotlab sweep` checks before its first case runs
                from rotlab.sweep.runner import plan_of

                plan_of(raw, scenario, str(path))
            typer.echo(f"{path}: ok ({scenario.time.sample_count:,} samples, method {scenario.solver.method})")
            for line in (*describe(scenario.body), *scenario.rotor_lines()):
                typer.echo(f"  {line[2:]}")
            _hint(scenario, f"{path}: ")
        except InputError as exc:
            failed += 1
            typer.echo(f"rotlab: error: {exc}", err=True)
    if failed:
        raise typer.Exit(2)


@app.command()
def stability(
    config: Annotated[Path, typer.Argument(help="Scenario TOML file whose initial state is a relative equilibrium.")],
    assignments: SetOption = None,
) -> None:
    """Linear stability of the initial state: eigenvalues and a verdict (a permanent rotation, a sleeping top)."""
    from rotlab.errors import InputError
    from rotlab.linear_stability import stability as analyse

    try:
        result = analyse(config, overrides=_overrides(assignments))
    except InputError as exc:
        _fail(exc)
    typer.echo(str(result))


@app.command()
def lyapunov(
    config: Annotated[Path, typer.Argument(help="Scenario TOML file.")],
    duration: Annotated[Optional[float], typer.Option("--duration", help="Seconds to measure over (default: the scenario's span).")] = None,
    check: Annotated[bool, typer.Option("--check", help="Also the cross-check: two whole runs a small distance apart, reset every 5 s.")] = False,
    assignments: SetOption = None,
) -> None:
    """Maximal Lyapunov exponent (1/s) with its convergence: Benettin's renormalisation on the method's tangent map."""
    from rotlab.errors import InputError, RunFailure
    from rotlab.lyapunov_exponent import divergence, lyapunov as measure

    overrides = _overrides(assignments)
    try:
        result = measure(config, duration=duration, overrides=overrides)
        typer.echo(str(result))
        if check:
            typer.echo(f"cross-check (two runs, reset every 5 s): {divergence(config, duration=duration, overrides=overrides):.6g} 1/s")
    except (InputError, RunFailure) as exc:
        _fail(exc)


@app.command()
def batch(
    paths: Annotated[list[Path], typer.Argument(help="Scenario files and/or directories of *.toml files.")],
    outdir: Annotated[Path, typer.Option("-o", "--outdir", help="Where recordings, summary.json and junit.xml go.")] = Path("batch-out"),
    jobs: Annotated[int, typer.Option("-j", "--jobs", min=1, help="Parallel worker processes.")] = 2,
    dask: Annotated[Optional[str], typer.Option("--dask", help="Run on an existing Dask cluster: tcp://HOST:PORT.")] = None,
    timeout: Annotated[Optional[float], typer.Option("--timeout", help="Per-case wall-clock limit in seconds (local workers).")] = None,
    retries: Annotated[int, typer.Option("--retries", min=0, help="Run a case again when its worker dies (default 0).")] = 0,
    markdown: Annotated[Optional[Path], typer.Option("--markdown", help="Write a Markdown summary to PATH (also appended to $GITHUB_STEP_SUMMARY when set).")] = None,
) -> None:
    """Run scenario suites in parallel; exit 1 if any scenario errs or breaks a [checks] bound
    (a scenario without [checks] is held to default bounds on its invariants)."""
    import os

    from rotlab.batch.reports import case_line, table, write_junit, write_markdown, write_summary
    from rotlab.batch.runner import collect_configs, run_batch
    from rotlab.errors import InputError, RunFailure
    from rotlab.outdir import prepare_outdir
    from rotlab.parallel import exit_after_stop

    try:
        _check_timeout(timeout, dask)
        configs = collect_configs(paths)
        prepare_outdir(outdir)
        if markdown is not None:
            prepare_outdir(markdown.parent if str(markdown.parent) else Path("."))
    except InputError as exc:
        _fail(exc)
    exit_after_stop()
    try:
        run = run_batch(configs, outdir, jobs, timeout=timeout, retries=retries, dask_address=dask,
                        on_result=lambda r: typer.echo(case_line(r)))
    except InputError as exc:  # the Dask scheduler cannot be reached
        _fail(exc)
    stopped = signal.Signals(run.stopped).name if run.stopped else None
    typer.echo(table(run.results))
    try:
        write_summary(run.results, outdir / "summary.json", stopped)
        write_junit(run.results, outdir / "junit.xml")
        if markdown is not None:
            write_markdown(run.results, markdown, append=False, stopped=stopped)
        if os.environ.get("GITHUB_STEP_SUMMARY"):
            write_markdown(run.results, Path(os.environ["GITHUB_STEP_SUMMARY"]), append=True, stopped=stopped)
    except RunFailure as exc:
        _fail(exc)
    if stopped:
        _stopped_line(f"rotlab: batch stopped by {stopped}: wrote the summary of the cases that finished")
    if run.exit_code:
        raise typer.Exit(run.exit_code)


def _stopped_line(text: str) -> None:
    """The one line a stopped batch/sweep prints (main() adds no "interrupted" after it)."""
    global _reported
    typer.echo(text, err=True)
    _reported = True


def _check_timeout(timeout: float | None, dask: str | None) -> None:
    from rotlab.errors import InputError

    if timeout is None:
        return
    if not (0 < timeout < float("inf")):
        raise InputError("--timeout", f"must be a positive number of seconds (got {timeout})")
    if dask is not None:
        raise InputError("--timeout", "not available with --dask (a running Dask task cannot be stopped): use the cluster's limits")


def _case_numbers(text: str | None, count: int) -> list[int]:
    """``--compare``'s case numbers ("3,17"), each in [0, count)."""
    from rotlab.errors import InputError

    if text is None:
        return []
    numbers = []
    for part in text.split(","):
        try:
            k = int(part)
        except ValueError:
            raise InputError("--compare", f"'{part.strip()}' is not a case number: give numbers separated by commas, as 3,17") from None
        if not 0 <= k < count:
            raise InputError("--compare", f"case {k} is not in this sweep: its cases are 0 … {count - 1}")
        numbers.append(k)
    return numbers


@app.command()
def sweep(
    config: Annotated[Path, typer.Argument(help="Scenario TOML file with a [sweep] section.")],
    outdir: Annotated[Path, typer.Option("-o", "--outdir", help="Where results.csv/.parquet and the comparison recording go.")] = Path("sweep-out"),
    jobs: Annotated[int, typer.Option("-j", "--jobs", min=1, help="Local worker processes.")] = 2,
    dask: Annotated[Optional[str], typer.Option("--dask", help="Run on an existing Dask cluster: tcp://HOST:PORT.")] = None,
    timeout: Annotated[Optional[float], typer.Option("--timeout", help="Per-case wall-clock limit in seconds (local workers).")] = None,
    retries: Annotated[int, typer.Option("--retries", min=0, help="Run a case again when its worker dies (default 0).")] = 0,
    compare: Annotated[Optional[str], typer.Option("--compare", help="Cases (numbers, comma-separated) whose series the comparison recording shows, besides 50 spread over the sweep.")] = None,
    device: Annotated[Optional[str], typer.Option("--device", help="cpu, or cuda: the ensemble kernels on an NVIDIA GPU (pip install 'rotlab[cuda]'); default [sweep] device, else cpu.")] = None,
) -> None:
    """Run a parameter sweep; exit 1 if any case errs or breaks a [checks] bound."""
    from contextlib import nullcontext

    from rotlab.errors import InputError, RunFailure
    from rotlab.sweep.runner import compared_cases, device_plan, plan, run_cases, start_workers

    try:
        _check_timeout(timeout, dask)
    except InputError as exc:
        _fail(exc)
    # the local workers start now: their imports run while this process imports and plans
    with start_workers(config, jobs) if dask is None else nullcontext() as warm:
        from rotlab.withheld import withhold_pandas, withhold_scipy_linalg
        withhold_scipy_linalg()  # numba would import SciPy's linear algebra to ask about BLAS for functions we never call
        from rotlab.heap import keep_heap, objects_frozen
        from rotlab.outdir import prepare_outdir
        from rotlab.parallel import exit_after_stop
        from rotlab.sweep.recording import write_comparison
        from rotlab.sweep.report import terminal_table, write_results
        from rotlab.sweep.results import PARTIAL_RESULTS, Results, parameter_names
        from rotlab.events import observable_names

        keep_heap()  # the ensemble path reports its cases here, and the results table is built here
        withhold_pandas()  # pyarrow would import pandas (time and memory) just to ask if our arrays are Series
        try:
            sweep_plan = plan(config)
            compared = compared_cases(len(sweep_plan.cases), _case_numbers(compare, len(sweep_plan.cases)))  # (before any file is made)
            on_gpu = device_plan(sweep_plan, device, "--device", dask, timeout)  # (--device over the file's [sweep] device)
            device = device if device is not None else sweep_plan.base.sweep.device  # (run_cases: the device decided here)
            prepare_outdir(outdir)
            exit_after_stop()
            # the results table: results.partial.csv grows as cases finish; the final files, the recording and the terminal read it
            results = Results(parameter_names(sweep_plan.cases[0].values), [], outdir / PARTIAL_RESULTS,
                              observable_names(list(sweep_plan.base.events)))
            with objects_frozen():  # (what was imported and planned: the cases' collections skip it)
                run = run_cases(sweep_plan, jobs=jobs, dask_address=dask, timeout=timeout, retries=retries, warm=warm,
                                on_outcomes=results.add, compared=compared, ensemble=on_gpu, device=device)
        except (InputError, RunFailure) as exc:  # (a GPU's failure: the cases that finished are in results.partial.csv)
            _fail(exc)
        except OSError as exc:
            _fail(RunFailure(f"could not write the sweep's results in {outdir}: {exc.strerror or exc}"))
    try:
        with interrupts.deferred():  # (every case is in: a stop signal now ends the command once its files are written)
            write_results(results, outdir)
            write_comparison(results, outdir / f"{config.stem}_sweep.rrd", sweep_plan.base.title)
    except (OSError, RunFailure) as exc:
        _fail(RunFailure(f"could not write the sweep's results in {outdir}: {getattr(exc, 'strerror', None) or exc}"))
    typer.echo(terminal_table(results, run.how))
    typer.echo(f"wrote {outdir / 'results.csv'}, {outdir / 'results.parquet'}, {outdir / (config.stem + '_sweep.rrd')}")
    if run.stopped:
        _stopped_line(f"rotlab: sweep stopped by {signal.Signals(run.stopped).name}: wrote the results of the cases that finished")
        raise typer.Exit(128 + run.stopped)
    if results.failing().shape[0]:
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
def animate(
    recording: Annotated[Path, typer.Argument(help="A recording written by `rotlab run`.")],
    output: Annotated[Path, typer.Option("-o", "--output", help="Animation to write: .gif, or .mp4 (needs ffmpeg).")] = Path("animation.gif"),
    fps: Annotated[float, typer.Option("--fps", help="Frames per second of the clip.")] = 20.0,
    speed: Annotated[float, typer.Option("--speed", help="Simulated seconds per second of clip.")] = 1.0,
    size: Annotated[str, typer.Option("--size", help="Frame size WIDTHxHEIGHT.")] = "640x640",
) -> None:
    """Animate the body (ellipsoid, axes, arrows, trailing trace) from a recording, for a report
    or a slide (needs matplotlib: pip install 'rotlab[plots]')."""
    from rotlab.errors import InputError, RunFailure
    from rotlab.recording.animate import animate as render
    from rotlab.recording.snapshot import parse_size

    try:
        path = render(recording, output, fps, speed, parse_size(size))
    except (InputError, RunFailure) as exc:
        _fail(exc)
    typer.echo(f"wrote {path}")


@app.command()
def plot(
    recordings: Annotated[list[Path], typer.Argument(help="Recordings written by `rotlab run` (or rotlab.save); several are overlaid.")],
    output: Annotated[Path, typer.Option("-o", "--output", help="Figure to write: .pdf, .svg or .png.")] = Path("figure.pdf"),
    panels: Annotated[Optional[str], typer.Option("--panels", help="Comma-separated panels (default: all; a wrong name lists them).")] = None,
    start: Annotated[Optional[float], typer.Option("--from", help="Start of the time span, s.")] = None,
    end: Annotated[Optional[float], typer.Option("--to", help="End of the time span, s.")] = None,
    size: Annotated[Optional[str], typer.Option("--size", help="Figure size WIDTHxHEIGHT in inches.")] = None,
) -> None:
    """Figures for a report (light background, units on every axis): the viewer's plots of a
    recording, its events and Poincaré sections; several recordings overlaid (needs matplotlib:
    pip install 'rotlab[plots]')."""
    from rotlab.errors import InputError, RunFailure
    from rotlab.recording.plot import plot as draw

    try:
        inches = None
        if size is not None:
            try:
                inches = tuple(float(x) for x in size.lower().split("x"))
                assert len(inches) == 2 and all(1 <= x <= 100 for x in inches)
            except (ValueError, AssertionError):
                raise InputError("--size", f"'{size}': give WIDTHxHEIGHT in inches, each 1 to 100, e.g. 8x10") from None
        keys = [k.strip() for k in panels.split(",") if k.strip()] if panels else None
        path, drawn = draw(recordings, output, keys, start, end, inches)
    except (InputError, RunFailure) as exc:
        _fail(exc)
    typer.echo(f"wrote {path}: {', '.join(p.key for p in drawn)}")


@app.command()
def export(
    recording: Annotated[Path, typer.Argument(help="A recording written by `rotlab run` (or rotlab.save).")],
    output: Annotated[Path, typer.Option("-o", "--output", help="Table to write: .csv or .parquet.")] = Path("run.csv"),
) -> None:
    """A run's samples as a table: the columns and units of Trajectory.to_dataframe, as CSV or Parquet."""
    from rotlab.errors import InputError, RunFailure
    from rotlab.recording.export import export as write

    try:
        path, rows, columns = write(recording, output)
    except (InputError, RunFailure) as exc:
        _fail(exc)
    typer.echo(f"wrote {path}: {rows:,} rows × {columns} columns")


@app.command()
def stress(
    quick: Annotated[bool, typer.Option("--quick", help="The subset that runs in under two minutes.")] = False,
    faults: Annotated[bool, typer.Option("--faults", help="Run the fault campaign instead: hostile inputs, paths and signals against the real CLI.")] = False,
    count: Annotated[int, typer.Option("--count", min=1, help="Fault campaign: inputs per category.")] = 40,
    seed: Annotated[int, typer.Option("--seed", min=0, help="Fault campaign: the seed (same seed, same inputs).")] = 0,
) -> None:
    """Run the stress suite of hard scenes (or, with --faults, the fault campaign); exit 0 only
    if every check passes."""
    if faults:
        _fault_campaign(count, seed)
        return
    from rotlab.stress.suite import run_suite

    def report(outcome) -> None:
        verdict = "PASS" if outcome.passed else "FAIL"
        typer.echo(f"{verdict}  {outcome.name:44} {outcome.figure}  [bound {outcome.bound}; {outcome.seconds:.1f} s]")

    outcomes = run_suite(quick, report)
    passed = sum(o.passed for o in outcomes)
    typer.echo(f"stress: {passed} of {len(outcomes)} checks passed")
    if passed < len(outcomes):
        raise typer.Exit(1)


def _fault_campaign(count: int, seed: int) -> None:
    from rotlab.stress.faults import run_campaign, table

    def report(verdict) -> None:
        if verdict.broken:
            typer.echo(f"BROKEN  {verdict.category}: {verdict.name}: {verdict.outcome} — {verdict.detail}")

    verdicts = run_campaign(seed, count, report)
    typer.echo(table(verdicts))
    broken = sum(v.broken for v in verdicts)
    typer.echo(f"faults: {len(verdicts)} inputs, {broken} broke a promise (seed {seed})")
    if broken:
        raise typer.Exit(1)


app.command(name="bench")(bench)


@app.command()
def new(kind: Annotated[TemplateKind, typer.Argument(help="The kind of scene.")]) -> None:
    """Print a commented scenario template: `rotlab new lagrange > my_top.toml`."""
    from importlib.resources import files

    typer.echo(files("rotlab").joinpath("templates", f"{kind}.toml").read_text(encoding="utf-8"), nl=False)


@app.command()
def schema() -> None:
    """Print the scenario file's JSON Schema (for editors: Taplo / Even Better TOML complete and
    check keys with it; the shipped configs name it in their first line)."""
    from rotlab.config.schema import schema_text

    typer.echo(schema_text(), nl=False)


def main(argv: list[str] | None = None) -> None:
    """Console entry point: every error is one line on stderr (usage errors too), exit codes
    0 success, 1 run failure, 2 bad input, 130 interrupted (Ctrl-C), 143 stopped by SIGTERM."""
    try:
        code = app(args=argv, standalone_mode=False)
    except click_errors.NoArgsIsHelpError as exc:
        exc.show()
        code = 2
    except click_errors.UsageError as exc:
        command = exc.ctx.command_path if exc.ctx is not None else "rotlab"
        typer.echo(f"rotlab: error: {exc.format_message().replace('Value error, ', '')} (see `{command} --help`)", err=True)
        code = exc.exit_code
    except click_errors.ClickException as exc:
        typer.echo(f"rotlab: error: {exc.format_message()}", err=True)
        code = exc.exit_code
    except (typer.Abort, KeyboardInterrupt):
        code = 130
    if code == 130 and not _reported:  # typer turns Ctrl-C into exit 130 without a word
        typer.echo("rotlab: interrupted", err=True)
    if code == 130:
        code = interrupts.exit_code()  # 143 when SIGTERM stopped it (the shell's convention)
    sys.exit(code if isinstance(code, int) else 0)
