"""Video -> canonical 3-D motion: :func:`track` runs BlazePose over every frame, then
:func:`lifting.reconstruct.lift_track` fills gaps, low-passes, fits the skeleton and finds the root path.

This module imports no torch: the torch side (:mod:`lifting.reconstruct`, about a second to import)
is imported on a thread while the frames are tracked (:func:`lift_video`, :mod:`lifting.preload`), so a
short video does not wait for it. The motion keeps the **video's frame rate** (callers resample, e.g. to the
canonical 20 fps for the models).
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from lifting import preload
from lifting.blazepose.results import TrackResult
from lifting.filtering import DEFAULT_CUTOFF_HZ
from lifting.upright import check_rotation, check_upright
from motioncore.span import Span, check_span

if TYPE_CHECKING:
    from lifting.blazepose.tracker import PoseTracker
    from lifting.reconstruct import LiftResult
    from motioncore.motion import Motion

Progress = bool | Callable[[str], None] | None
TRUNCATED_FRACTION = 0.9  # fewer decoded frames than this share of the container's count: truncated


class _Reporter:
    """Progress in frames: a tqdm bar (``True``), a callable given a line every ~10 %, or nothing."""

    def __init__(self, progress: Progress, total: int, label: str):
        self.callback = progress if callable(progress) else None
        self.total, self.label, self.done, self.next_report = total, label, 0, 0
        self.bar = None
        if progress is True:
            from tqdm import tqdm

            self.bar = tqdm(total=total, unit="frame", desc=label)

    def update(self, n: int = 1) -> None:
        self.done += n
        if self.bar is not None:
            self.bar.update(n)
        elif self.callback is not None and (self.done >= self.next_report or self.done == self.total):
            self.callback(f"{self.label}: frame {self.done}/{self.total}")
            self.next_report = self.done + max(1, self.total // 10)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def track(
    path: str | Path,
    progress: Progress = None,
    tracker: PoseTracker | None = None,
    span: Span = (None, None),
    rotate: int = 0,
) -> TrackResult:
    """BlazePose over every frame of a video (frames are decoded one at a time).

    ``span = (start, end)`` seconds: only frames with ``start <= time < end`` are tracked (None: open end).
    ``rotate``: 0, 90, 180 or 270 degrees clockwise, applied to every frame before tracking.
    Raises ValueError naming the file for a missing file, one that is not a video, one without
    frames, one that decodes to clearly fewer frames than its header promises (truncated), and a
    span that holds no frame.
    """
    # onnxruntime and OpenCV are imported only where frames are tracked (not by a parent whose child tracks)
    from lifting.blazepose.tracker import PoseFrame, PoseTracker
    from lifting.video import iter_frames, prefetched, video_info

    path = Path(path)
    start_s, end_s = check_span(span, str(path))
    fps, expected, width, height = video_info(path, rotate)
    tracker = tracker if tracker is not None else PoseTracker()
    tracker.reset()
    frames: list[PoseFrame] = []
    times: list[float] = []
    decoded = 0
    bar = _Reporter(progress, expected, f"{path.name}: tracking")
    try:
        for _, time_s, frame in prefetched(iter_frames(path, rotate)):  # decoding overlaps tracking
            decoded += 1
            bar.update()
            if (start_s is not None and time_s < start_s - 1e-9) or (end_s is not None and time_s >= end_s - 1e-9):
                continue
            frames.append(tracker.process(frame, time_s))
            times.append(time_s)
    finally:
        bar.close()
    if decoded < TRUNCATED_FRACTION * expected - 1:
        raise ValueError(
            f"{path}: the video looks truncated: decoded {decoded} of the {expected} frames its header lists"
        )
    if not frames:
        raise ValueError(f"{path}: --start/--end select no frames (the video is {decoded / fps:.2f} s long)")
    return TrackResult.stack(frames, times, fps, width, height)


def lift_video(
    path: str | Path,
    progress: Progress = None,
    cutoff_hz: float | None = DEFAULT_CUTOFF_HZ,
    tracker: PoseTracker | None = None,
    span: Span = (None, None),
    rotate: int | None = None,
    **options,
) -> LiftResult:
    """:func:`track` + :func:`lifting.reconstruct.lift_track` for a video file (``options`` go to
    ``lift_track``); ``span``: ``(start, end)`` seconds of the video to use.

    ``rotate``: degrees clockwise (0, 90, 180, 270) to turn the frames before tracking; None (default):
    as they are, and a ValueError naming ``--rotate`` when the person is upside down or on their side
    in most frames (:func:`lifting.upright.check_upright`)."""
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
    if rotate is None:
        check_upright(result, path)
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
