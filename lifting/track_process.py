"""Tracking in a child process, so that the parent's import of the lift's torch side runs beside it
without sharing a GIL with the tracking loop (:func:`lifting.lift.lift_video` uses it in a process
that has not imported that side yet; measured in docs/RESULTS.md, "The first hour").

The child (``python -m lifting.track_process VIDEO START END PROGRESS CORES``) runs
:func:`lifting.lift.track` with ONNX inference on one core fewer than the machine has (``CORES``; at most
the tracker's default threads), so the parent's import keeps a core: on this 2-core box that
took a 73-frame video from 2.40 s to 2.18 s (medians of 8 alternating runs) and a 230-frame one from
4.7 s to 4.9 s, with identical output. It writes one pickled reply to stdout: ``("ok", TrackResult)``,
or the name and message of an error a user can act on (a bad video's ValueError, the models'
ModelUnavailableError), raised again here; its progress bar and messages go to the inherited stderr. Only this
parent reads what its own child wrote, so the pickle is never untrusted input.
"""

from __future__ import annotations

import os
import pickle
import subprocess
import sys
from pathlib import Path

from lifting.blazepose.results import TrackResult
from motioncore.span import Span


class ChildFailedError(RuntimeError):
    """The child gave no reply (it could not start or died); the caller may track in-process instead."""


def track_in_child(path: str | Path, progress: bool = False, span: Span = (None, None)) -> TrackResult:
    """:func:`lifting.lift.track` of ``path`` run by a child Python; raises the same one-line errors."""
    cores = max(1, (os.cpu_count() or 2) - 1)  # one left to this process's import
    args = [str(path), *("-" if s is None else repr(float(s)) for s in span), "1" if progress else "0", str(cores)]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in sys.path if p))  # the modules this process sees
    proc = subprocess.run([sys.executable, "-m", "lifting.track_process", *args], stdout=subprocess.PIPE, env=env,
                          check=False)
    try:
        status, payload = pickle.loads(proc.stdout)
    except Exception:  # noqa: BLE001 - no reply at all: the child died (its own error is on stderr above)
        raise ChildFailedError(f"{path}: the tracking process exited with status {proc.returncode} without a result") from None
    if status == "ValueError":
        raise ValueError(payload)
    if status == "ModelUnavailableError":  # imported only here: assets imports onnxruntime
        from lifting.blazepose.assets import ModelUnavailableError

        raise ModelUnavailableError(payload)
    return payload


def main(argv: list[str] | None = None) -> None:
    from lifting.blazepose.assets import ModelUnavailableError
    from lifting.blazepose.runtime import DEFAULT_THREADS
    from lifting.blazepose.tracker import PoseTracker
    from lifting.lift import track

    video, start, end, progress, cores = argv if argv is not None else sys.argv[1:]
    span = tuple(None if s == "-" else float(s) for s in (start, end))
    try:
        reply = ("ok", track(video, progress == "1", PoseTracker(num_threads=min(DEFAULT_THREADS, int(cores))), span))
    except ModelUnavailableError as error:  # the errors a user can act on travel back as they are
        reply = ("ModelUnavailableError", str(error))
    except ValueError as error:
        reply = ("ValueError", str(error))
    sys.stdout.buffer.write(pickle.dumps(reply))
    sys.stdout.buffer.flush()
    import gc

    gc.freeze()  # the exit skips a last sweep over the imports' objects (as video2style.cli.console_main)


if __name__ == "__main__":
    main()
