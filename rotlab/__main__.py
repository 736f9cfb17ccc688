"""The ``rotlab`` executable (``python -m rotlab`` and the console script)."""

from __future__ import annotations

import signal
import sys


def entry() -> None:
    """``rotlab.cli.main`` with Ctrl-C made safe at both ends: held while the command line loads
    (typer, rich), raised once it has loaded; ignored after ``main``, when every file is finished
    and the exit code known (~0.5 s of library teardown, where a late Ctrl-C would otherwise end
    the process by the signal itself: exit −2, no message)."""
    from rotlab import interrupts

    try:
        with interrupts.deferred():
            from rotlab.cli import main
    except KeyboardInterrupt:
        sys.stderr.write("rotlab: interrupted\n")
        sys.exit(130)
    try:
        main()
    finally:
        signal.signal(signal.SIGINT, signal.SIG_IGN)


if __name__ == "__main__":
    entry()
