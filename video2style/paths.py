"""Where video2style keeps things on a user's machine."""
from __future__ import annotations

import os
import shutil
import sys
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


def console_script() -> Path:
    """The ``video2style`` console script installed beside this interpreter (what a user's shell runs in
    this environment; a pyenv shim on PATH would add its own start-up), else the one on PATH."""
    beside = Path(sys.executable).with_name("video2style")
    return beside if beside.is_file() else Path(shutil.which("video2style") or "video2style")
