"""Where video2style keeps things on a user's machine."""
from __future__ import annotations

import os
from pathlib import Path


def cache_dir() -> Path:
    """``$VIDEO2STYLE_CACHE``, else ``$XDG_CACHE_HOME/video2style``, else ``~/.cache/video2style``."""
    env = os.environ.get("VIDEO2STYLE_CACHE")
    if env:
        return Path(env).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "video2style"


def default_dataset_dir() -> Path:
    return cache_dir() / "dataset"
