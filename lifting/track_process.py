"""Tracking in a child process, so that the parent's import of the lift's torch side runs beside it
without sharing a GIL with the tracking loop (:func:`lifting.lift.lift_video` uses it in a process
that has not imported that side yet; measured in
docs/archive/RESULTS-notebook.md#third-round-2026-12-02-tracking-in-a-child-process).

The child (``python -m lifting.track_process VIDEO START END PROGRESS CORES ROTATE PARENT``) runs
:func:`lifting.tracking.track` with ONNX inference on one core fewer than the machine has (``CORES``; at most
the tracker's default threads), so the parent's import keeps a core: on this 2-core box that
took a 73-frame video from 2.40 s to 2.18 s (medians of 8 alternating runs) and a 230-frame one from
4.7 s to 4.9 s, with identical output. It writes one pickled reply to stdout: ``("ok", TrackResult)``,
or the name and message of an error a user can act on (a bad video's ValueError, the models'
ModelUnavailableError), raised again here; its progress bar and messages go to the inherited stderr. Only this
parent reads what its own child wrote, so the pickle is never untrusted input.

The child dies with its parent (``kill -9`` of ``pose`` would otherwise leave it tracking to the end of
the video; ``learn`` and ``batch`` give a progress callable and track in their own process): on Linux the kernel sends it SIGKILL when the parent goes
(``prctl(PR_SET_PDEATHSIG)``), and everywhere a watcher thread ends it within
:data:`WATCH_S` once its parent process ``PARENT`` is no longer its parent.
"""

from __future__ import annotations

import os
import pickle
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

from lifting.blazepose.results import TrackResult
from motioncore.span import Span

WATCH_S = 0.25  # the watcher's poll of the parent (the fallback where prctl is missing)
_PR_SET_PDEATHSIG = 1


class ChildFailedError(RuntimeError):
    """The child gave no reply (it could not start or died); the caller may track in-process instead."""


def track_in_child(path: str | Path, progress: bool = False, span: Span = (None, None), rotate: int = 0) -> TrackResult:
    """:func:`lifting.tracking.track` of ``path`` run by a child Python; raises the same one-line errors."""
    cores = max(1, (os.cpu_count() or 2) - 1)  # one left to this process's import
    args = [str(path), *("-" if s is None else repr(float(s)) for s in span), "1" if progress else "0", str(cores),
            str(int(rotate)), str(os.getpid())]
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


def die_with_parent(parent: int) -> None:
    """End this process when ``parent`` (its parent's pid) exits: SIGKILL from the kernel on Linux, and a
    daemon thread that polls the parent pid every :data:`WATCH_S` s (other systems, or prctl refused)."""
    if sys.platform.startswith("linux"):
        try:
            import ctypes

            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
        except (OSError, AttributeError):  # no libc prctl: the watcher below still runs
            pass

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(WATCH_S)
        os._exit(1)  # the parent is gone: no reply can be read, nothing to clean up

    if os.getppid() != parent:  # it died before prctl took effect
        os._exit(1)
    threading.Thread(target=watch, name="parent-watch", daemon=True).start()


def main(argv: list[str] | None = None) -> None:
    video, start, end, progress, cores, rotate, parent = argv if argv is not None else sys.argv[1:]
    die_with_parent(int(parent))
    from lifting.blazepose.assets import ModelUnavailableError
    from lifting.blazepose.runtime import DEFAULT_THREADS
    from lifting.blazepose.tracker import PoseTracker
    from lifting.tracking import track

    span = tuple(None if s == "-" else float(s) for s in (start, end))
    try:
        tracker = PoseTracker(num_threads=min(DEFAULT_THREADS, int(cores)))
        reply = ("ok", track(video, progress == "1", tracker, span, int(rotate)))
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
