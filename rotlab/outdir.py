"""The output directory of ``rotlab batch`` / ``sweep``: created and proven writable before any
case runs, so an unwritable place is a one-line input error (exit 2), not a traceback after the
whole run."""

from __future__ import annotations

from pathlib import Path

from rotlab.errors import InputError


def prepare_outdir(outdir: Path) -> None:
    """Create ``outdir`` (and its parents) and check that files can be created in it."""
    from rotlab.recording.writer import check_output_path

    where = f"--outdir {outdir}"
    if outdir.exists() and not outdir.is_dir():
        raise InputError(where, "is a file: give a directory")
    try:
        outdir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(where, f"cannot create the directory ({exc.strerror}): choose another place with -o") from None
    try:
        check_output_path(outdir / "summary.json")
    except InputError as exc:
        raise InputError(where, exc.message) from None
