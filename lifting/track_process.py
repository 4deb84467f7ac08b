"""Tracking in a child process, so that the parent's import of the lift's torch side runs beside it
without sharing a GIL with the tracking loop (:func:`lifting.lift.lift_video` uses it in a process
that has not imported that side yet; measured in docs/RESULTS.md, "The first hour").

The child (``python -m lifting.track_process VIDEO START END PROGRESS``) runs :func:`lifting.lift.track`
and writes one pickled reply to stdout: ``("ok", TrackResult)`` or ``("error", message)`` for the
ValueError a bad video raises; its progress bar and messages go to the inherited stderr. Only this
parent reads what its own child wrote, so the pickle is never untrusted input.
"""

from __future__ import annotations

import pickle
import subprocess
import sys
from pathlib import Path

from lifting.blazepose.tracker import TrackResult
from motioncore.span import Span


def track_in_child(path: str | Path, progress: bool = False, span: Span = (None, None)) -> TrackResult:
    """:func:`lifting.lift.track` of ``path`` run by a child Python; raises the same one-line ValueError."""
    args = [str(path), *("-" if s is None else repr(float(s)) for s in span), "1" if progress else "0"]
    proc = subprocess.run([sys.executable, "-m", "lifting.track_process", *args], stdout=subprocess.PIPE, check=False)
    try:
        status, payload = pickle.loads(proc.stdout)
    except Exception:  # noqa: BLE001 - no reply at all: the child died (its own error is on stderr above)
        raise RuntimeError(f"{path}: the tracking process exited with status {proc.returncode} without a result") from None
    if status == "error":
        raise ValueError(payload)
    return payload


def main(argv: list[str] | None = None) -> None:
    from lifting.lift import track

    video, start, end, progress = argv if argv is not None else sys.argv[1:]
    span = tuple(None if s == "-" else float(s) for s in (start, end))
    try:
        reply = ("ok", track(video, progress == "1", span=span))
    except ValueError as error:
        reply = ("error", str(error))
    sys.stdout.buffer.write(pickle.dumps(reply))
    sys.stdout.buffer.flush()


if __name__ == "__main__":
    main()
