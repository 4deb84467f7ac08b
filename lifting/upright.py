"""Is the tracked person upright in the frames? A video filmed upside down, or a phone video stored on
its side without a rotation tag, is tracked as well as an upright one (BlazePose turns its crop to the
body), but the lift assumes a level camera: the figure would come out upside down or lying down.

:func:`frame_turn` reads the person's up direction in the image from the 2-D landmarks (the shoulders'
midpoint seen from the ankles' midpoint: a person bending over or sitting still points up) and
:func:`check_upright` refuses, in one line naming ``--rotate``, a video where most tracked frames show
the person turned by a quarter turn or more. ``--rotate 0`` keeps the frames as they are (a person who
really lies down or stands on their hands).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from lifting.blazepose.results import POSE_LANDMARKS, TrackResult

_SHOULDERS = [POSE_LANDMARKS.index("left_shoulder"), POSE_LANDMARKS.index("right_shoulder")]
_ANKLES = [POSE_LANDMARKS.index("left_ankle"), POSE_LANDMARKS.index("right_ankle")]
ROTATIONS = (0, 90, 180, 270)  # --rotate: degrees clockwise, applied to the frames as OpenCV shows them
MAJORITY = 0.5  # more than this share of the tracked frames turned the same way: the video is turned
_WHERE = {90: "to the right of", 180: "below", 270: "to the left of"}
_TURNED = {90: "a quarter turn clockwise", 180: "upside down", 270: "a quarter turn counter-clockwise"}


def check_rotation(rotate: int | None) -> int:
    """``rotate`` (degrees clockwise; None: 0) checked against :data:`ROTATIONS`."""
    if rotate is None:
        return 0
    if isinstance(rotate, bool) or rotate not in ROTATIONS:
        raise ValueError(f"--rotate expected one of 0, 90, 180, 270 (degrees clockwise), got {rotate!r}")
    return int(rotate)


def frame_turns(image: np.ndarray) -> np.ndarray:
    """Per frame, how far the person's up direction is turned clockwise from the image's up, rounded to
    0, 90, 180 or 270 degrees; -1 where the landmarks are missing.

    ``image``: (T,33,2+) landmark pixels (x right, y down), NaN where not tracked. Returns (T,) int.
    """
    image = np.asarray(image)
    if image.ndim != 3 or image.shape[1] != len(POSE_LANDMARKS) or image.shape[2] < 2:
        raise ValueError(f"expected landmark pixels (T,{len(POSE_LANDMARKS)},2+), got {image.shape}")
    up = image[:, _SHOULDERS, :2].mean(1) - image[:, _ANKLES, :2].mean(1)  # (T,2)
    degrees = np.degrees(np.arctan2(up[:, 0], -up[:, 1]))  # 0: up, 90: right (clockwise), 180: down
    turns = (np.round(degrees / 90).astype(np.int64) % 4) * 90 if len(up) else np.zeros(0, np.int64)
    valid = np.isfinite(up).all(1) & (np.hypot(up[:, 0], up[:, 1]) > 0)
    return np.where(valid, turns, -1)


def frame_turn(track: TrackResult) -> tuple[int, float]:
    """``(turn, share)``: the clockwise turn (0, 90, 180, 270) of the person in most tracked frames of
    ``track`` and the share of tracked frames that show it; ``(0, 0.0)`` when nothing was tracked."""
    turns = frame_turns(track.image[track.found] if len(track.found) else track.image)
    turns = turns[turns >= 0]
    if not len(turns):
        return 0, 0.0
    counts = np.bincount(turns // 90, minlength=4)
    best = int(np.argmax(counts))
    return best * 90, float(counts[best] / len(turns))


def check_upright(track: TrackResult, path: str | Path, rotate: int | None = None) -> None:
    """Raise a one-line ValueError naming ``path`` and the ``--rotate`` that makes the person upright
    when most of the tracked frames show them turned (upside down, or on their side). ``rotate``: the turn
    the frames were given before tracking (``--rotate``; None or 0: none), said when it is what turned them."""
    turn, share = frame_turn(track)
    if turn and share > MAJORITY and rotate:
        fix = (rotate - turn) % 360
        instead = "leave --rotate out" if fix == 0 else f"run again with --rotate {fix}"
        raise ValueError(
            f"{path}: --rotate {rotate} leaves the person {_TURNED[turn]} (head {_WHERE[turn]} their feet in "
            f"{share:.0%} of the tracked frames); {instead} (or --rotate 0 if the person really is turned)"
        )
    if turn and share > MAJORITY:
        fix = (360 - turn) % 360
        raise ValueError(
            f"{path}: the person's head is {_WHERE[turn]} their feet in {share:.0%} of the tracked frames: the "
            f"video looks turned {_TURNED[turn]}; run again with --rotate {fix} (or --rotate 0 if the person "
            "really is turned)"
        )
