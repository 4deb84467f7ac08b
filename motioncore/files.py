"""Writing output files atomically: a temporary name in the target folder, then one rename.

Every writer in the project goes through :func:`atomic_output` (or :func:`atomic_write_text`), so a
failure, Ctrl-C or SIGTERM never leaves a half-written file under the real name, and the temporary
names all have one shape (``.NAME.v2s-tmp-xxxxxxxx<suffix>``, :func:`temp_beside`) that a batch can sweep after a
killed run without touching a user's own files (:func:`is_temp_name`).
"""
from __future__ import annotations

import os
import re
import stat
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

TEMP_MARK = ".v2s-tmp-"  # in every temporary name we make, and in no name we publish
TEMP_NAME_BYTES = 120  # of a file's name, at most this much goes into its temporary name
_TEMP_NAME = re.compile(r"^\..+" + re.escape(TEMP_MARK) + r"[a-z0-9_]{8}\.[A-Za-z0-9]+$")


def temp_beside(path: str | os.PathLike, suffix: str | None = None) -> Path:
    """A new empty file beside ``path`` (its folder made if needed), ``.NAME.v2s-tmp-xxxxxxxx<suffix>`` (NAME: the first
    :data:`TEMP_NAME_BYTES` bytes of the path's name): made with
    O_EXCL (never an existing file, never through a symlink planted there), mode 0600 until :func:`publish`.
    ``suffix``: default the path's own, ``.tmp`` if it has none."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    # the name cut short where it is long: a legal 244-character name must not make a temporary one too long
    short = os.fsdecode(os.fsencode(path.name)[:TEMP_NAME_BYTES])
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{short}{TEMP_MARK}",
                               suffix=(suffix or path.suffix or ".tmp")[:16])
    os.close(fd)
    return Path(tmp)


def is_temp_name(name: str) -> bool:
    """Whether a file name has the shape of :func:`temp_beside`'s files (a user's ``.notes.20241201.tmp`` has not)."""
    return bool(_TEMP_NAME.match(name))


def publish(tmp: str | os.PathLike, path: str | os.PathLike) -> Path:
    """Give ``tmp`` (e.g. from ``tempfile.mkstemp``, which makes 0600 files) the usual permissions
    (0666 minus the umask) and rename it to ``path`` in one step; returns ``path``."""
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)
    os.replace(tmp, path)
    return Path(path)


@contextmanager
def atomic_output(path: str | os.PathLike, suffix: str | None = None) -> Iterator[Path]:
    """``with atomic_output(path) as tmp:`` write ``tmp``; on leaving the block it becomes ``path``.

    ``tmp`` is an empty file beside ``path`` (its folder made if needed); ``suffix`` (default: the
    path's own, ``.tmp`` if it has none) keeps file-type sniffing writers (OpenCV, matplotlib)
    happy. On any exception, the temporary file is removed and ``path`` is left as it was."""
    tmp = temp_beside(path, suffix)
    try:
        yield Path(tmp)
        publish(tmp, path)
    finally:
        Path(tmp).unlink(missing_ok=True)


def atomic_write_text(path: str | os.PathLike, text: str) -> None:
    """Write ``text`` (UTF-8, ``\\n`` newlines) to ``path`` atomically."""
    with atomic_output(path, ".tmp") as tmp, open(tmp, "w", encoding="utf-8", newline="\n") as f:
        f.write(text)


def check_regular_file(path: str | os.PathLike, what: str = "file") -> None:
    """Refuse, in one line (ValueError), an input that is not a regular file, before anything opens it: a FIFO
    with no writer would hang ``open()`` for good, a device could be read forever. Symlinks are followed; a
    missing path raises FileNotFoundError naming it."""
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise FileNotFoundError(f"{path}: no such {what}") from None
    if not stat.S_ISREG(st.st_mode):
        kind = ("a folder" if stat.S_ISDIR(st.st_mode) else "a FIFO (named pipe)" if stat.S_ISFIFO(st.st_mode)
                else "a socket" if stat.S_ISSOCK(st.st_mode) else "a device" if stat.S_ISCHR(st.st_mode) or
                stat.S_ISBLK(st.st_mode) else "not a regular file")
        raise ValueError(f"{path}: is {kind}, not a {what}; give a regular file")
