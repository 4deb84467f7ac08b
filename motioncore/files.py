"""Publishing output files atomically: write to a temporary name in the target folder, then rename."""
from __future__ import annotations

import os
from pathlib import Path


def publish(tmp: str | os.PathLike, path: str | os.PathLike) -> Path:
    """Give ``tmp`` (e.g. from ``tempfile.mkstemp``, which makes 0600 files) the usual permissions
    (0666 minus the umask) and rename it to ``path`` in one step; returns ``path``."""
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)
    os.replace(tmp, path)
    return Path(path)
