"""How a rotlab process ends: the executable and the batch/sweep workers finish their own files,
then leave without the interpreter's teardown."""

from __future__ import annotations

import atexit
import os
import sys
from typing import NoReturn


def leave(code: object) -> NoReturn:
    """End the process with ``code`` (``sys.exit``'s meaning) once every file rotlab wrote is
    finished: the atexit handlers run and the output streams are flushed, then ``os._exit`` skips
    the interpreter's teardown of numba's, LLVM's and Rerun's objects, a sizeable share of a
    short run's wall time.  No rotlab output depends on that teardown, and
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
