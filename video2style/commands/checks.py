"""The refusals every command makes before any work, each in one line (:class:`CliError`): an output location that
cannot be written, a disk without room, a training run's folder that is one of its inputs."""
from __future__ import annotations

import os
from pathlib import Path

from video2style.paths import check_outputs


class CliError(Exception):
    """A user-facing error: printed as one line, exit status 1."""


def writable(path: Path, flag: str, is_dir: bool = False) -> Path:
    """Check an output location before any work: a file path must not be a folder, a folder must not be
    a file, no name in it may be longer than the disk takes, and the nearest existing folder above must be
    writable. Returns ``path``."""
    path = Path(path)
    check_name_lengths(path, flag)
    if not is_dir and path.is_dir():
        raise CliError(f"{path}: {flag} names a folder; give a file name")
    if is_dir and path.exists() and not path.is_dir():
        raise CliError(f"{path}: {flag} names a file; give a folder")
    parent = path if is_dir else path.parent
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    if not parent.is_dir():
        raise CliError(f"{parent}: is a file, so {flag} {path} cannot be made inside it")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise CliError(f"{parent}: cannot write here ({flag} {path})")
    return path


def check_name_lengths(path: Path, flag: str) -> None:
    """Refuse, before any work, an output whose name (or a folder's on the way) is longer than the disk takes."""
    existing = Path(os.path.abspath(path))
    while existing != existing.parent and not os.path.isdir(existing):
        existing = existing.parent
    try:
        most = os.pathconf(existing, "PC_NAME_MAX")
    except (OSError, ValueError):
        most = 255
    for part in Path(path).parts:
        if len(os.fsencode(part)) > most:
            raise CliError(f"{path}: {flag}: the name {part[:40]}... is {len(os.fsencode(part))} bytes long; this disk "
                           f"takes names up to {most} bytes")


STYLE_FILE_BYTES = 8 << 20  # room a style file needs: about 0.6 MB of adapters and up to 20 s of example


def free_space(path: Path, need: int, flag: str) -> None:
    """Refuse, before any work, an output on a disk with less than ``need`` bytes free (learning takes minutes
    and a full disk would only be found when writing)."""
    import shutil

    where = Path(path).parent
    while not where.exists() and where != where.parent:
        where = where.parent
    free = shutil.disk_usage(where).free
    if free < need:
        raise CliError(f"{path}: only {free / 1e6:.1f} MB free on its disk ({flag}); {need / 1e6:.0f} MB are needed")


def run_folder_checks(args, names: list[str], inputs: list[tuple[str, Path | None]] = (),
                       outputs: list[tuple[str, Path]] = ()) -> None:
    """A training command's refusals before any work: ``--out`` (and the files ``names`` it writes there, and
    ``outputs``) must not be the ``--data`` folder or another input (:func:`video2style.paths.check_outputs`)."""
    check_outputs([("--out", args.out)] + [("--out", args.out / name) for name in names] + list(outputs),
                  data_inputs(args.data) + list(inputs))


def data_inputs(data: Path) -> list[tuple[str, Path]]:
    """The dataset cache a command reads: its folder and files (:func:`mlcore.dataset.build_dataset` writes them)."""
    return [("the --data folder", data)] + [("a --data file", data / name)
                                            for name in ("features.safetensors", "clips.json", "split.json")]
