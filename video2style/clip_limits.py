"""How long a clip that apply and learn take may be: the one refusal of the whole-clip reader
(:func:`video2style.pipeline.read_clip`) and of a long take read a span at a time (:mod:`video2style.long_takes`)."""
from __future__ import annotations

from pathlib import Path

from motioncore.skeleton import CANONICAL

MAX_CLIP_SECONDS = 6 * 3600.0  # longer takes (or a frame time that stretches a small file over days) are refused
MIN_FRAMES = 10  # canonical frames: a shorter clip is refused


def check_length(path: Path, frames: int, fps: float) -> None:
    """Refuse a clip of ``frames`` frames at ``fps`` (as read) longer than :data:`MAX_CLIP_SECONDS`."""
    if frames / fps > MAX_CLIP_SECONDS:
        raise ValueError(f"{path}: {frames / fps / 3600:.1f} hours long ({frames} frames at {fps:g} fps); "
                         f"clips up to {MAX_CLIP_SECONDS / 3600:g} hours are taken: split it")


def check_frames(path: Path, frames: int) -> None:
    """Refuse a clip of fewer than :data:`MIN_FRAMES` canonical frames."""
    if frames < MIN_FRAMES:
        raise ValueError(f"{path}: too short ({frames} frames at {CANONICAL.fps:g} fps; need at least {MIN_FRAMES})")
