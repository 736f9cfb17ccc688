"""pytest plugin (entry point ``pytest11``): scenario files with ``[checks]`` as test items.

    pytest configs/                  # each configs/*.toml with [checks] is one test
    pytest --rotlab-scenarios        # also in directories pytest reaches on its own (testpaths)

A ``*.toml`` file is collected when it has a top-level ``[checks]`` table and either it lies under
a path named on the command line or ``--rotlab-scenarios`` (ini: ``rotlab_scenarios = true``)
is given, so installing rotlab never changes what another project's plain ``pytest`` collects.
The item runs the scenario (no recording), evaluates its checks exactly as ``rotlab batch`` does,
and fails with the batch report's lines; every check's value and bound become the test's
``user_properties`` (``--junitxml`` writes them as properties).  ``-k``, ``-x``, ``--junitxml``
and pytest-xdist work as for any test.  Nothing heavy is imported until an item runs.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("rotlab")
    group.addoption("--rotlab-scenarios", action="store_true", default=False,
                    help="collect rotlab scenario files (*.toml with [checks]) wherever pytest looks")
    parser.addini("rotlab_scenarios", type="bool", default=False, help="collect rotlab scenario files with [checks]")


def pytest_collect_file(file_path: Path, parent: pytest.Collector) -> pytest.Collector | None:
    if file_path.suffix != ".toml" or not _enabled_for(file_path, parent.config):
        return None
    if not _has_checks(file_path):
        return None
    return ScenarioFile.from_parent(parent, path=file_path)


def _enabled_for(path: Path, config: pytest.Config) -> bool:
    if config.getoption("rotlab_scenarios") or config.getini("rotlab_scenarios"):
        return True
    root = config.invocation_params.dir
    for arg in config.invocation_params.args:
        named = Path(str(arg).split("::")[0])
        named = named if named.is_absolute() else root / named
        if named.exists() and (path == named.resolve() or named.resolve() in path.resolve().parents):
            return True
    return False


def _has_checks(path: Path) -> bool:
    """A scenario with [checks], or a file that cannot be read as TOML (not UTF-8, bad syntax, a
    number too long): collected, so that it fails as one item with its one-line reason while
    the scenarios beside it run."""
    from rotlab.config.loader import read_toml
    from rotlab.errors import InputError

    try:
        return isinstance(read_toml(path).get("checks"), dict)
    except InputError:
        return True


class ScenarioFailed(Exception):
    """A scenario broke a check or could not run: ``lines`` are the batch report's."""

    def __init__(self, lines: list[str]) -> None:
        super().__init__("\n".join(lines))
        self.lines = lines


class ScenarioFile(pytest.File):
    def collect(self):
        yield ScenarioItem.from_parent(self, name=self.path.stem)


class ScenarioItem(pytest.Item):
    """Run one scenario and hold it to its ``[checks]`` (the batch's ``run_case`` logic)."""

    def runtest(self) -> None:
        from rotlab import api
        from rotlab.batch.reports import case_line
        from rotlab.batch.runner import ERROR, CaseResult, error_text
        from rotlab.checks import evaluate_checks
        from rotlab.errors import InputError

        try:
            traj = api.simulate(api.load(self.path), check=False)  # a stopped run fails its "run" check
        except InputError as exc:
            raise ScenarioFailed([case_line(CaseResult(self._shown(), None, ERROR, message=error_text(exc, self.path)))]) from None
        checks = evaluate_checks(traj, defaults=True)
        for check in checks:
            self.user_properties.append((f"{check.name}.value", _text(check.value)))
            self.user_properties.append((f"{check.name}.bound", _text(check.bound)))
        failed = [c for c in checks if not c.passed]
        if failed:
            head = f"FAIL      {self._shown()}: " + "; ".join(c.message for c in failed)
            raise ScenarioFailed([head, *(f"  {'ok  ' if c.passed else 'FAIL'} {c.name}: {c.message}" for c in checks)])

    def _shown(self) -> str:
        return self.nodeid.split("::")[0]

    def repr_failure(self, excinfo: pytest.ExceptionInfo[BaseException], style: Any = None) -> str:
        if isinstance(excinfo.value, ScenarioFailed):
            return str(excinfo.value)
        return super().repr_failure(excinfo, style=style)

    def reportinfo(self) -> tuple[Path, int, str]:
        return self.path, 0, f"rotlab scenario {self.path.name}"


def _text(value: float | None) -> str:
    return "null" if value is None else f"{value:.17g}"
