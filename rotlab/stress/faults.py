"""The fault campaign (``rotlab stress --faults``): hostile inputs, paths and signals thrown at the
real command line, each in a process of its own, with every outcome classified.

A run must end in one of the promised ways: exit 0 with a readable recording, or exit 1 (run
stopped), 2 (bad input), 130 (Ctrl-C) or 143 (SIGTERM) with exactly one line on stderr and no traceback;
within a time limit; leaving no temporary file, the input untouched and a pre-existing recording
either intact or (exit 0 only) replaced by a complete one.  Inputs come from a seeded generator:
the same seed gives the same campaign.
"""

from __future__ import annotations

import os
import random
import re
import signal
import stat
import subprocess
import sys
import tempfile
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterator

SENTINEL = b"a previous recording that only a complete run may replace"
TIME_LIMIT = 60.0  # s per attempt: beyond it the attempt is a hang

# Values thrown at every assignment of a shipped config: wrong types, non-finite, and magnitudes
# each side of the accepted ranges (|x| <= 1e30, positive >= 1e-30, |t| <= 9e9 s, 1 ns).
BAD_VALUES = [
    "nan", "inf", "-inf", "1e308", "-1e308", "1e-320", "0", "-1", '"text"', "true", "[]", "[1, 2]",
    "[nan, 0, 0]", "[1e308, 1e308, 1e308]", "{}", "{ x = 1 }", "[[1, 2], [3]]", "1979-05-27", '"\\u00e9"',
    "[0, 0, 0, 0]", "123456789012345678901234567890", '[1, "a", 3]',
    "1e30", "-1e30", "1.0000001e30", "1e-30", "9.9e-31", "5e-324", "-5e-324", "9e9", "9.000001e9", "1e15",
    "[1e30, 1e30, 1e30]", "[1e-30, 1e-30, 1e-30]", "[5e-324, 0, 0]", "9" * 40, "-" + "9" * 400,
    "{ on = 0, off = 1e-10 }", "{ on = 0.5, off = 0.5000000000001 }", "[0, 1e-10, 1]",
]
_ASSIGNMENT = re.compile(rb"^(\s*[A-Za-z_\"][^=\n]*=\s*)(.+)$", re.M)


@dataclass
class Attempt:
    """One hostile run: ``argv`` (after ``rotlab``) in a fresh directory holding ``files``;
    ``prepare(dir)`` makes special files; ``interrupt_after`` sends ``stop_signal`` (SIGINT: Ctrl-C,
    or SIGTERM: kill) after that many s."""

    category: str
    name: str
    argv: list[str | bytes]
    files: dict[str, bytes] = field(default_factory=dict)
    prepare: Callable[[Path], None] | None = None
    interrupt_after: float | None = None
    stop_signal: int = signal.SIGINT
    expect: Callable[[int, str], str | None] | None = None  # the category's own promise: (exit, stderr) → what broke


@dataclass(frozen=True)
class Verdict:
    category: str
    name: str
    outcome: str  # "ran", "clean error", or what broke: "traceback", "hang", "file lost", ...
    detail: str = ""

    @property
    def broken(self) -> bool:
        return self.outcome not in ("ran", "clean error")


def shipped_configs() -> dict[str, bytes]:
    """The shipped scenario files (package data of the installed rotlab), name → bytes."""
    from rotlab.shipped import shipped_configs as folder

    return {path.name: path.read_bytes() for path in sorted(folder().glob("*.toml"))}


def _run_short(config: str) -> list[str]:
    return ["run", config, "-o", "out.rrd", "--duration", "0.05", "-q"]


def config_values(rng: random.Random, count: int) -> Iterator[Attempt]:
    configs = shipped_configs()
    for k in range(count):
        name = rng.choice(sorted(configs))
        text = configs[name]
        spots = list(_ASSIGNMENT.finditer(text))
        for _ in range(rng.randint(1, 3)):
            spot = rng.choice(spots)
            text = text.replace(spot.group(0), spot.group(1) + rng.choice(BAD_VALUES).encode(), 1)
            spots = list(_ASSIGNMENT.finditer(text))
        yield Attempt("config values", f"{name} #{k}", _run_short("in.toml"), {"in.toml": text})


def config_bytes(rng: random.Random, count: int) -> Iterator[Attempt]:
    configs = shipped_configs()
    for k in range(count):
        name = rng.choice(sorted(configs))
        data = bytearray(configs[name])
        for _ in range(rng.randint(1, 8)):
            at = rng.randrange(len(data))
            action = rng.choice(("flip", "insert", "delete"))
            if action == "flip":
                data[at] ^= 1 << rng.randrange(8)
            elif action == "insert":
                data[at:at] = bytes(rng.randrange(256) for _ in range(rng.randint(1, 4)))
            else:
                del data[at]
        yield Attempt("config bytes", f"{name} #{k}", _run_short("in.toml"), {"in.toml": bytes(data)})


def special_inputs(rng: random.Random, count: int) -> Iterator[Attempt]:
    def fifo(d: Path) -> None:
        os.mkfifo(d / "in.toml")

    def loop(d: Path) -> None:
        os.symlink(d / "in.toml", d / "in.toml")

    cases = [
        Attempt("special inputs", "/dev/zero", _run_short("/dev/zero")),
        Attempt("special inputs", "/dev/urandom", _run_short("/dev/urandom")),
        Attempt("special inputs", "FIFO", _run_short("in.toml"), prepare=fifo),
        Attempt("special inputs", "symlink loop", _run_short("in.toml"), prepare=loop),
        Attempt("special inputs", "directory", _run_short(".")),
        Attempt("special inputs", "nested 1,000 deep", _run_short("in.toml"), {"in.toml": b"a = " + b"[" * 1000 + b"]" * 1000}),
        Attempt("special inputs", "dotted key 100,000 parts", _run_short("in.toml"), {"in.toml": b"a" + b".a" * 100_000 + b" = 1"}),
        Attempt("special inputs", "17 MB", _run_short("in.toml"), {"in.toml": b"# " + b"x" * 17_000_000}),
        Attempt("special inputs", "empty", _run_short("in.toml"), {"in.toml": b""}),
        Attempt("special inputs", "not UTF-8", _run_short("in.toml"), {"in.toml": b"title = \"\xff\xfe\"\n"}),
    ]
    yield from cases[:count] if count < len(cases) else cases


def output_paths(rng: random.Random, count: int) -> Iterator[Attempt]:
    config = shipped_configs()["euler.toml"]

    def fifo(d: Path) -> None:
        os.mkfifo(d / "pipe.rrd")

    def device(d: Path) -> None:  # a private copy of /dev/null: a failure here harms nothing
        os.mknod(d / "null.rrd", stat.S_IFCHR | 0o666, os.makedev(1, 3))

    def readonly_dir(d: Path) -> None:
        (d / "ro").mkdir()
        (d / "ro").chmod(0o500)

    short = ["--duration", "0.05", "-q"]
    cases = [
        Attempt("output paths", "-o the config itself", ["run", "in.toml", "-o", "in.toml", *short], {"in.toml": config}),
        Attempt("output paths", "-o a FIFO", ["run", "in.toml", "-o", "pipe.rrd", *short], {"in.toml": config}, prepare=fifo),
        Attempt("output paths", "-o a character device", ["run", "in.toml", "-o", "null.rrd", *short], {"in.toml": config}, prepare=device),
        Attempt("output paths", "-o a 300-character name", ["run", "in.toml", "-o", "x" * 296 + ".rrd", *short], {"in.toml": config}),
        Attempt("output paths", "-o a non-UTF-8 name", ["run", "in.toml", "-o", b"\xff\xfe.rrd", *short], {"in.toml": config}),
        Attempt("output paths", "-o a directory", ["run", "in.toml", "-o", ".", *short], {"in.toml": config}),
        Attempt("output paths", "-o in a missing directory", ["run", "in.toml", "-o", "no/such/dir/x.rrd", *short], {"in.toml": config}),
        Attempt("output paths", "-o under /proc", ["run", "in.toml", "-o", "/proc/rotlab.rrd", *short], {"in.toml": config}),
        Attempt("output paths", "-o in an unwritable directory", ["run", "in.toml", "-o", "ro/x.rrd", *short], {"in.toml": config}, prepare=readonly_dir),
    ]
    yield from cases[:count] if count < len(cases) else cases


def options(rng: random.Random, count: int) -> Iterator[Attempt]:
    config = shipped_configs()["lagrange.toml"]
    choices = [
        ["--duration", rng.choice(["nan", "inf", "-1", "0", "1e300", "abc", "1e-300", ""])],
        ["--method", rng.choice(["leapfrog", "", "RK4", "auto ", "exact"])],
        ["--set", rng.choice(["initial.omega=[0,0,1e31]", "body.mass=-1", "x", "=", "loads[99].value=1", "time.end=abc",
                              "initial.omega[7]=1", "solver.rtol=0", "a" + ".a" * 70 + "=1"])],
        ["--output"],
        ["--bogus"],
    ]
    for k in range(count):
        extra = rng.choice(choices)
        yield Attempt("options", f"{' '.join(extra)} #{k}", ["run", "in.toml", "-o", "out.rrd", "-q", *extra, "--duration", "0.05"],
                      {"in.toml": config})


FREE_BODY = b"[body]\nprincipal_moments = [1.0, 2.0, 2.5]\n[initial]\nomega = [0.1, 0.2, 0.3]\n[time]\nend = 2.0\nsample_rate = 50\n"


def _load_methods() -> tuple[str, ...]:
    """``auto`` and every method of the catalog that runs a body with a formula torque."""
    from rotlab.config import parse_scenario
    from rotlab.methods.registry import all_methods
    from rotlab.scene.scene import build_scene

    scene = build_scene(parse_scenario({"body": {"principal_moments": [1.0, 2.0, 2.5]}, "time": {"end": 1.0},
                                        "loads": [{"type": "expression", "frame": "body", "torque": ["1", "0", "0"]}]}))
    return ("auto", *(m.name for m in all_methods() if m.unsupported(scene) is None))


def _fails_naming(*words: str, code: int = 1) -> Callable[[int, str], str | None]:
    """The promise of an input that cannot succeed: exit ``code``, and the one line says one of ``words``."""
    def check(exit_code: int, err: str) -> str | None:
        if exit_code != code or not any(w in err for w in words):
            return f"expected exit {code} saying {' or '.join(map(repr, words))}, got exit {exit_code}: {err.strip()[:150]}"
        return None
    return check


def failing_loads(rng: random.Random, count: int) -> Iterator[Attempt]:
    """A load formula that is not finite from some time on (or at t = 0), in a random component,
    frame and method: the run must stop (exit 1) naming that formula — never exit 0."""
    methods = _load_methods()
    for k in range(count):
        a = round(rng.uniform(0.1, 1.9), 3)
        formula = rng.choice([f"sqrt({a} - t)", f"log({a} - t)", f"({a} - t)**(-0.5)", f"0.01*({a} - t)**0.25",
                              "1/t", "t**(-1)", "t**(-3)", "log(t)", f"0.1*sqrt({a} - t)*omega[0]"])
        component, frame, method = rng.randrange(3), rng.choice(["body", "space"]), rng.choice(methods)
        torque = ['"0"'] * 3
        torque[component] = f'"{formula}"'
        text = FREE_BODY + f'[[loads]]\ntype = "expression"\nframe = "{frame}"\ntorque = [{", ".join(torque)}]\n'.encode()
        yield Attempt("failing loads", f"{formula} in torque[{component}], {frame}, {method}",
                      ["run", "in.toml", "-o", "out.rrd", "-q", "--method", method], {"in.toml": text},
                      # an adaptive method may close in on a pole and stop there, its step collapsed, before any value is not finite
                      expect=_fails_naming(f"loads[0].torque[{component}] = '{formula}'", f"step size fell below the floating-point resolution at t = {a:.9g}"))


def centre_of_mass(rng: random.Random, count: int) -> Iterator[Attempt]:
    """Random axisymmetric tops, mass and centre-of-mass heights: refused (exit 2, naming
    body.center_of_mass) exactly when no body has those moments about the fixed point with that
    mass there (S_c = ½ tr I − I − m r rᵀ not positive semidefinite, computed here apart)."""
    for k in range(count):
        a = 10 ** rng.uniform(-5, -2)
        c = a * rng.uniform(0.1, 1.9)
        m = 10 ** rng.uniform(-2, 1)
        z = 10 ** rng.uniform(-3, 0)
        realisable = 0.5 * (2 * a + c) - a >= -1e-9 * (a + 0.5 * c) and 0.5 * (2 * a + c) - c - m * z * z >= -1e-9 * (a + 0.5 * c)
        text = (f"[body]\nprincipal_moments = [{a!r}, {a!r}, {c!r}]\nmass = {m!r}\ncenter_of_mass = [0.0, 0.0, {z!r}]\n"
                "[initial]\nomega = [0.0, 0.0, 50.0]\naxis_angle = [0.3, 0.0, 0.0]\n[[loads]]\ntype = \"gravity\"\n[time]\nend = 0.05\n").encode()

        def expect(code: int, err: str, realisable: bool = realisable) -> str | None:
            refused = code == 2 and "body.center_of_mass" in err
            return None if refused != realisable else f"realisable = {realisable}, exit {code}: {err.strip()[:150]}"

        yield Attempt("centre of mass", f"A = {a:.3g}, C = {c:.3g}, m = {m:.3g}, z = {z:.3g}", _run_short("in.toml"), {"in.toml": text}, expect=expect)


VECTORS = {"initial.omega": 3, "body.center_of_mass": 3, "initial.quaternion": 4, "initial.axis_angle": 3}


def vector_lengths(rng: random.Random, count: int) -> Iterator[Attempt]:
    """A vector of the wrong length: exit 2, saying how many components it needs and has."""
    for k in range(count):
        key = rng.choice(sorted(VECTORS))
        needed = VECTORS[key]
        given = rng.choice([n for n in range(1, 7) if n != needed])
        table, name = key.split(".")
        line = f"{name} = [{', '.join(['0.1'] * given)}]\n".encode()
        body = b"[body]\nprincipal_moments = [1.0, 2.0, 2.5]\nmass = 1.0\n"
        text = (body + line if table == "body" else body + b"[initial]\n" + line) + b"[time]\nend = 1.0\n"
        yield Attempt("vector lengths", f"{key} of {given}", _run_short("in.toml"), {"in.toml": text},
                      expect=_fails_naming(f"{key}: needs {needed} components, got {given}", code=2))


def huge_literals(rng: random.Random, count: int) -> Iterator[Attempt]:
    """Integers of 4,301 to 200,000 digits in the file, or to 100,000 in --set (an argument holds
    at most 128 kB): exit 2, one line."""
    for k in range(count):
        in_file = rng.random() < 0.5
        digits = "9" * rng.randint(4301, 200_000 if in_file else 100_000)
        if in_file:
            yield Attempt("huge literals", f"{len(digits)} digits in the file", _run_short("in.toml"),
                          {"in.toml": FREE_BODY.replace(b"end = 2.0", b"end = " + digits.encode())}, expect=_fails_naming("a number too long", code=2))
        else:
            yield Attempt("huge literals", f"{len(digits)} digits in --set", [*_run_short("in.toml"), "--set", f"initial.omega[0]={digits}"],
                          {"in.toml": FREE_BODY}, expect=_fails_naming("a number too long", code=2))


def reversed_ranges(rng: random.Random, count: int) -> Iterator[Attempt]:
    """A sweep's random range with low ≥ high: `rotlab validate` refuses it (exit 2), so the sweep
    never starts."""
    for k in range(count):
        low = round(rng.uniform(0.01, 1.0), 3)
        high = low if rng.random() < 0.3 else round(low - rng.uniform(0.001, 1.0), 3)
        kind = rng.choice(["uniform", "log_uniform"]) if high > 0 else "uniform"
        text = FREE_BODY + f'[sweep]\nsamples = 2\n[sweep.parameters]\n"initial.omega[0]" = {{ {kind} = [{low}, {high}] }}\n'.encode()
        yield Attempt("reversed ranges", f"{kind} [{low}, {high}]", ["validate", "in.toml"], {"in.toml": text},
                      expect=_fails_naming("needs low < high", code=2))


def signals(rng: random.Random, count: int) -> Iterator[Attempt]:
    """Ctrl-C or SIGTERM (alternately) at a random moment of a run long enough to be caught
    anywhere: start-up, compiling, stepping, converting or writing."""
    config = shipped_configs()["general.toml"]
    for k in range(count):
        after = round(rng.uniform(0.2, 6.0), 2)
        signum = (signal.SIGINT, signal.SIGTERM)[k % 2]
        yield Attempt("signals", f"{signal.Signals(signum).name} after {after} s", ["run", "in.toml", "-o", "out.rrd", "-q", "--duration", "3000"],
                      {"in.toml": config}, interrupt_after=after, stop_signal=signum)


CATEGORIES: dict[str, Callable[[random.Random, int], Iterator[Attempt]]] = {
    "config values": config_values,
    "config bytes": config_bytes,
    "special inputs": special_inputs,
    "output paths": output_paths,
    "options": options,
    "signals": signals,
    "failing loads": failing_loads,
    "centre of mass": centre_of_mass,
    "vector lengths": vector_lengths,
    "huge literals": huge_literals,
    "reversed ranges": reversed_ranges,
}


def attempts(seed: int, count: int) -> list[Attempt]:
    """``count`` attempts per category (fixed lists are cut to ``count``), from ``seed``."""
    out: list[Attempt] = []
    for name, make in CATEGORIES.items():
        out.extend(make(random.Random(f"{seed}:{name}"), count))
    return out


def run_attempt(attempt: Attempt, time_limit: float = TIME_LIMIT) -> Verdict:
    """Run one attempt in a fresh directory and classify what happened."""
    with tempfile.TemporaryDirectory(prefix="rotlab-fault-") as tmp:
        d = Path(tmp)
        (d / "out.rrd").write_bytes(SENTINEL)
        for name, content in attempt.files.items():
            (d / name).write_bytes(content)
        if attempt.prepare is not None:
            attempt.prepare(d)
        inputs = {name: (d / name).read_bytes() for name in attempt.files}
        before = set(os.listdir(d))
        return _classify(attempt, d, before, inputs, *_execute(attempt, d, time_limit))


def _execute(attempt: Attempt, d: Path, time_limit: float) -> tuple[int | None, str]:
    proc = subprocess.Popen([sys.executable, "-m", "rotlab", *attempt.argv], cwd=d, stdin=subprocess.DEVNULL,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, start_new_session=True)
    deadline = time.monotonic() + time_limit
    try:
        if attempt.interrupt_after is not None:
            try:
                proc.wait(timeout=attempt.interrupt_after)
            except subprocess.TimeoutExpired:
                proc.send_signal(attempt.stop_signal)
        _, err = proc.communicate(timeout=max(0.1, deadline - time.monotonic()))
        return proc.returncode, err.decode("utf-8", "replace")
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()
        return None, ""


def _classify(attempt: Attempt, d: Path, before: set[str], inputs: dict[str, bytes], code: int | None, err: str) -> Verdict:
    def verdict(outcome: str, detail: str = "") -> Verdict:
        return Verdict(attempt.category, attempt.name, outcome, detail[:200])

    if code is None:
        return verdict("hang", f"no exit within {TIME_LIMIT:g} s")
    if "Traceback" in err:
        return verdict("traceback", err.strip().splitlines()[-1] if err.strip() else "")
    if code not in (0, 1, 2, 130, 143):
        return verdict("bad exit code", f"exit {code}: {err.strip()[:160]}")
    lines = err.strip().splitlines()
    if code != 0 and not (len(lines) == 1 and lines[0].startswith("rotlab: ")):
        return verdict("messy error", f"exit {code}, {len(lines)} stderr lines: {err.strip()[:160]}")
    for name, content in inputs.items():
        path = d / name
        if path.is_file() and not path.is_symlink() and path.read_bytes() != content:
            return verdict("input clobbered", name)
    if (d / "null.rrd").exists() and not stat.S_ISCHR(os.stat(d / "null.rrd").st_mode):
        return verdict("special file replaced", "null.rrd")
    if (d / "pipe.rrd").exists() and not stat.S_ISFIFO(os.stat(d / "pipe.rrd").st_mode):
        return verdict("special file replaced", "pipe.rrd")
    leftovers = [n for n in set(os.listdir(d)) - before if n.endswith((".tmp", ".probe"))]
    if leftovers:
        return verdict("temp file left", ", ".join(sorted(leftovers)))
    out = d / "out.rrd"
    if code != 0 and (not out.exists() or out.read_bytes() != SENTINEL):
        return verdict("file lost", "a failed run replaced or removed out.rrd")
    for name in sorted(set(os.listdir(d)) - before | ({"out.rrd"} if code == 0 else set())):
        if name.endswith(".rrd") and (d / name).is_file() and (d / name).read_bytes() != SENTINEL:
            problem = _unreadable(d / name)
            if problem:
                return verdict("corrupt recording", f"{name}: {problem}")
    broken = attempt.expect(code, err) if attempt.expect is not None else None
    if broken:
        return verdict("wrong outcome", broken)
    return verdict("ran" if code == 0 else "clean error", lines[0] if lines else "")


def _unreadable(path: Path) -> str | None:
    """Why the recording cannot be read back whole (None when it can)."""
    try:
        from rerun.chunk import RrdReader

        for _ in RrdReader(str(path)).stream():
            pass
    except Exception as exc:  # any reader failure is what this check reports
        return f"{type(exc).__name__}: {exc}"
    return None


def run_campaign(seed: int, count: int, report: Callable[[Verdict], None] | None = None, jobs: int = 2) -> list[Verdict]:
    """Every attempt of ``attempts(seed, count)``, ``jobs`` at a time (each in its own process)."""
    from concurrent.futures import ThreadPoolExecutor

    if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:  # started in the background: children would ignore SIGINT too
        signal.signal(signal.SIGINT, signal.default_int_handler)
    verdicts: list[Verdict] = []
    with ThreadPoolExecutor(max_workers=jobs) as pool:
        for verdict in pool.map(run_attempt, attempts(seed, count)):
            verdicts.append(verdict)
            if report is not None:
                report(verdict)
    return verdicts


def table(verdicts: list[Verdict]) -> str:
    """Markdown: inputs per category, clean outcomes, and each kind of break (0 is the target)."""
    kinds = ["traceback", "hang", "file lost", "corrupt recording", "input clobbered", "special file replaced",
             "temp file left", "messy error", "bad exit code", "wrong outcome"]
    rows = ["| category | inputs | ran | clean errors | " + " | ".join(kinds) + " |", "|---" * (4 + len(kinds)) + "|"]
    for category in dict.fromkeys(v.category for v in verdicts):
        counts = Counter(v.outcome for v in verdicts if v.category == category)
        rows.append(f"| {category} | {sum(counts.values())} | {counts['ran']} | {counts['clean error']} | "
                    + " | ".join(str(counts[k]) for k in kinds) + " |")
    return "\n".join(rows)
