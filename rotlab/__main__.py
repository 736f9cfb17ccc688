"""The ``rotlab`` executable (``python -m rotlab`` and the console script)."""

from __future__ import annotations

import atexit
import os
import signal
import sys
from typing import NoReturn


def entry() -> NoReturn:
    """``rotlab.cli.main`` with Ctrl-C made safe at both ends, and SIGTERM made a Ctrl-C that exits
    143 (``rotlab.interrupts``): held while the command line loads (typer, rich), raised once it
    has loaded; ignored after ``main``, when every file is finished and the exit code known.
    Then ``leave``: the process ends without the interpreter's teardown."""
    from rotlab import interrupts

    interrupts.stop_on_sigterm()
    try:
        with interrupts.deferred():
            from rotlab.cli import main
    except KeyboardInterrupt:
        sys.stderr.write("rotlab: interrupted\n")
        leave(interrupts.exit_code())
    try:
        main()
        code: object = 0
    except SystemExit as done:
        code = done.code
    finally:
        for signum in interrupts.STOP_SIGNALS:
            signal.signal(signum, signal.SIG_IGN)
    leave(code)


def leave(code: object) -> NoReturn:
    """End the process with ``code`` (``sys.exit``'s meaning) once every file rotlab wrote is
    finished: the atexit handlers run and the output streams are flushed, then ``os._exit`` skips
    the interpreter's teardown of numba's, LLVM's and Rerun's objects, ~0.2 s of a 1 s run
    (`rotlab run configs/lagrange.toml`, measured).  No rotlab output depends on that teardown, and
    a signal that arrives there can no longer end the process by itself (exit −2)."""
    if code is None:
        status = 0
    elif isinstance(code, int):
        status = code
    else:  # sys.exit("message"): printed, status 1
        sys.stderr.write(f"{code}\n")
        status = 1
    rerun = sys.modules.get("rerun")
    if rerun is not None:  # rotlab finished its recordings itself; Rerun's exit hook would wait, without
        rerun.unregister_shutdown()  # a limit, on a live viewer that stopped reading (rerun-io/rerun#12620)
    try:
        atexit._run_exitfuncs()
        sys.stdout.flush()
        sys.stderr.flush()
    except (OSError, ValueError):  # a closed or broken pipe (rotlab … | head): nothing more to say
        pass
    os._exit(status & 0xFF)


if __name__ == "__main__":
    entry()
