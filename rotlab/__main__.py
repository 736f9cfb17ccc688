"""The ``rotlab`` executable (``python -m rotlab`` and the console script)."""

from __future__ import annotations

import signal
import sys
from typing import NoReturn


def entry() -> NoReturn:
    """``rotlab.cli.main`` with Ctrl-C made safe at both ends, and SIGTERM made a Ctrl-C that exits
    143 (``rotlab.interrupts``): held while the command line loads (typer, rich), raised once it
    has loaded; ignored after ``main``, when every file is finished and the exit code known.
    Then ``ending.leave``: the process ends without the interpreter's teardown."""
    from rotlab import ending, interrupts

    interrupts.stop_on_sigterm()
    try:
        with interrupts.deferred():
            from rotlab.cli import main
    except KeyboardInterrupt:
        sys.stderr.write("rotlab: interrupted\n")
        ending.leave(interrupts.exit_code())
    try:
        main()
        code: object = 0
    except SystemExit as done:
        code = done.code
    finally:
        for signum in interrupts.STOP_SIGNALS:
            signal.signal(signum, signal.SIG_IGN)
    ending.leave(code)


if __name__ == "__main__":
    entry()
