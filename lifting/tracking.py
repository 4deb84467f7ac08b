"""Video -> BlazePose track: :func:`track` runs the pose tracker over every frame of a video (or a span of it),
with a progress report in frames (:class:`FrameProgress`). :mod:`lifting.lift` calls it here or has
:mod:`lifting.track_process` call it in a child. Imports no torch (onnxruntime and OpenCV only where frames are
tracked), so the lift's torch side can be imported beside it.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from lifting.blazepose.results import TrackResult
from motioncore.span import Span, check_span

if TYPE_CHECKING:
    from lifting.blazepose.tracker import PoseTracker

Progress = bool | Callable[[str], None] | None
TRUNCATED_FRACTION = 0.9  # fewer decoded frames than this share of the container's count: truncated


class FrameProgress:
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
    bar = FrameProgress(progress, expected, f"{path.name}: tracking")
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
