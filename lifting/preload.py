"""Import a heavy module on a thread while other work runs (torch and the skeleton fit: about a second).

``start(name)`` as early as the module is known to be needed, ``finish(name)`` where it is used: the
import runs beside the tracking loop, whose ONNX inference and decoding release the GIL. This module
imports nothing heavy, so a command can call :func:`start` before its own imports.
"""

from __future__ import annotations

import importlib
import sys
import threading
from types import ModuleType

RECONSTRUCT = "lifting.reconstruct"  # the lift's torch side, needed once the frames are tracked
_threads: dict[str, threading.Thread] = {}
_errors: dict[str, BaseException] = {}


def start(name: str) -> None:
    """Begin importing module ``name`` on a daemon thread (nothing if it is imported or on its way)."""
    if name in sys.modules or name in _threads:
        return

    def run() -> None:
        try:
            importlib.import_module(name)
        except BaseException as error:  # noqa: BLE001 - raised by finish(), in the caller's thread
            _errors[name] = error

    _threads[name] = thread = threading.Thread(target=run, name=f"import {name}", daemon=True)
    thread.start()


def finish(name: str) -> ModuleType:
    """Module ``name``, once a background import of it is done; raises what that import raised."""
    thread = _threads.pop(name, None)
    if thread is not None:
        thread.join()
    if name in _errors:
        raise _errors.pop(name)
    return importlib.import_module(name)
