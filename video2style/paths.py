"""Where video2style keeps things on a user's machine, and the one check that its outputs never overwrite its
inputs (:func:`check_outputs`)."""
from __future__ import annotations

import os
import shutil
import sys
from pathlib import Path

LOCK_NAME = ".video2style.lock"  # held by the batch or apply writing a folder; it also marks that folder as results


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


def _keys(path, dirs: dict | None = None) -> tuple:
    """How a path is told apart: its device and inode where it exists (hard links, symlinks and every spelling of one
    file meet there), else its real path (symlinks and ``..`` resolved): a path that does not exist yet is never an
    existing file, and two that do not exist meet by their real paths. ``dirs`` caches the real paths of folders
    (a library's outputs share a few)."""
    try:
        st = os.stat(path)
    except OSError:
        head, name = os.path.split(os.fspath(path))
        if dirs is None or name in ("", ".", "..") or os.path.islink(path):
            return (os.path.realpath(path),)
        if head not in dirs:
            dirs[head] = os.path.realpath(head or ".")
        return (os.path.join(dirs[head], name),)
    return ((st.st_dev, st.st_ino),)


def same_path(a: str | os.PathLike, b: str | os.PathLike) -> bool:
    """Whether ``a`` and ``b`` name one file or folder (``./x``, ``../d/x``, a symlink or a hard link to it)."""
    return bool(set(_keys(a)) & set(_keys(b)))


def inside(path: str | os.PathLike, folder: str | os.PathLike) -> bool:
    """Whether ``path`` is ``folder`` or lies below it (real paths: symlinks followed)."""
    p, f = Path(os.path.realpath(path)), Path(os.path.realpath(folder))
    return p == f or f in p.parents


def check_outputs(outputs, inputs) -> None:
    """Refuse, before any work, a run whose outputs would overwrite its inputs or one another: the one check every
    command makes.

    ``outputs``: ``(option, path)`` for each file or folder the run writes (e.g. ``("-o", out / "x.bvh")``);
    ``inputs``: ``(what, path)`` for each file or folder it reads (e.g. ``("the input video", video)``). ``None``
    paths are left out. Paths are compared as files: by inode where they exist, else by real path. Raises a
    one-line ValueError naming the output, the option and the input."""
    seen, dirs = {}, {}
    for what, path in inputs:
        if path is not None:
            for key in _keys(path, dirs):
                seen.setdefault(key, ("in", what, path))
    for option, path in outputs:
        if path is None:
            continue
        keys = _keys(path, dirs)
        for key in keys:
            if key in seen:
                side, what, other = seen[key]
                if side == "in":
                    raise ValueError(f"{path}: {option} is {what} {other}: results would overwrite the input; "
                                     "give another path")
                if option == what:
                    raise ValueError(f"{path}: {option} would write this file twice in one run; give distinct paths")
                raise ValueError(f"{path}: {what} and {option} name the same file; give each its own")
        for key in keys:
            seen.setdefault(key, ("out", option, path))


def check_no_links(root: str | os.PathLike, folders, option: str = "-o") -> None:
    """Refuse, in one line, a folder the run would write into below ``root`` (``root`` itself is the user's choice)
    that is reached through a symbolic link: someone who can write to a shared ``root`` could point it at the
    user's own files, and results would replace them there."""
    root = Path(root)
    for folder in folders:
        folder = Path(folder)
        try:
            rel = folder.relative_to(root)
        except ValueError:
            continue
        here = root
        for part in rel.parts:
            here = here / part
            if here.is_symlink():
                raise ValueError(f"{here}: is a symbolic link inside {option} {root}; results are not written "
                                 "through links there (remove it if you did not make it)")
