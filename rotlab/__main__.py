"""The ``rotlab`` executable (``python -m rotlab`` and the console script)."""

from __future__ import annotations

import signal
import sys


def entry() -> None:
    """``rotlab.cli.main`` with Ctrl-C made safe at both ends, and SIGTERM made a Ctrl-C that exits
    143 (``rotlab.interrupts``): held while the command line loads (typer, rich), raised once it
    has loaded; ignored after ``main``, when every file is finished and the exit code known (~0.5 s
    of library teardown, where a late signal would end the process by itself: exit −2, no message)."""
    from rotlab import interrupts

    interrupts.stop_on_sigterm()
    try:
        with interrupts.deferred():
            from rotlab.cli import main
    except KeyboardInterrupt:
        sys.stderr.write("rotlab: interrupted\n")
        interrupts.forget_handled_interrupt()
        sys.exit(interrupts.exit_code())
    try:
        main()
    finally:
        for signum in interrupts.STOP_SIGNALS:
            signal.signal(signum, signal.SIG_IGN)
        interrupts.forget_handled_interrupt()


if __name__ == "__main__":
    entry()
