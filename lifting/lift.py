"""Video -> canonical 3-D motion: :func:`lifting.tracking.track` runs BlazePose over every frame, then
:func:`lifting.reconstruct.lift_track` fills gaps, low-passes, fits the skeleton and finds the root path.

This module imports no torch: the torch side (:mod:`lifting.reconstruct`, about a second to import)
is imported on a thread while the frames are tracked (:func:`lift_video`, :mod:`lifting.preload`), so a
short video does not wait for it. The motion keeps the **video's frame rate** (callers resample, e.g. to the
canonical 20 fps for the models).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING

from lifting import preload
from lifting.filtering import DEFAULT_CUTOFF_HZ
from lifting.tracking import Progress, track
from lifting.upright import check_rotation, check_upright
from motioncore.span import Span

if TYPE_CHECKING:
    from lifting.blazepose.tracker import PoseTracker
    from lifting.reconstruct import LiftResult
    from motioncore.motion import Motion


def lift_video(
    path: str | Path,
    progress: Progress = None,
    cutoff_hz: float | None = DEFAULT_CUTOFF_HZ,
    tracker: PoseTracker | None = None,
    span: Span = (None, None),
    rotate: int | None = None,
    **options,
) -> LiftResult:
    """:func:`lifting.tracking.track` + :func:`lifting.reconstruct.lift_track` for a video file (``options`` go to
    ``lift_track``); ``span``: ``(start, end)`` seconds of the video to use.

    ``rotate``: degrees clockwise (0, 90, 180, 270) to turn the frames before tracking; None (default):
    as they are, and a ValueError naming ``--rotate`` when the person is upside down or on their side
    in most frames (:func:`lifting.upright.check_upright`), as after any turn but 0 (a turn that turns an upright
    video is refused the same way)."""
    turn = check_rotation(rotate)
    t0 = time.perf_counter()
    fresh = preload.RECONSTRUCT not in sys.modules
    preload.start(preload.RECONSTRUCT)  # imported beside the tracking
    result = None
    if fresh and tracker is None and not callable(progress) and sys.executable:  # the import and tracking share no GIL
        from lifting.track_process import ChildFailedError, track_in_child

        try:
            result = track_in_child(path, bool(progress), span, turn)
        except ChildFailedError:  # e.g. an embedding application whose sys.executable is not Python
            result = None
    if result is None:
        result = track(path, progress, tracker, span, turn)
    if rotate != 0:  # --rotate 0: the frames as they are, whatever they show
        check_upright(result, path, rotate)
    t1 = time.perf_counter()
    lifted = preload.finish(preload.RECONSTRUCT).lift_track(result, str(path), cutoff_hz, **options)
    lifted.info["track_s"] = t1 - t0
    lifted.info["lift_s"] = time.perf_counter() - t1
    return lifted


def video_to_motion(
    path: str | Path,
    progress: Progress = None,
    cutoff_hz: float | None = DEFAULT_CUTOFF_HZ,
    span: Span = (None, None),
    rotate: int | None = None,
    **options,
) -> Motion:
    """A video of one person -> canonical :class:`Motion` at the **video's frame rate** (resample
    to 20 fps for the models). ``progress``: True for a bar in frames, a callable taking a line of
    text, or None/False. ``rotate``: as :func:`lift_video`. Raises ValueError (one line, naming the
    file) for unusable videos."""
    return lift_video(path, progress, cutoff_hz, span=span, rotate=rotate, **options).motion
