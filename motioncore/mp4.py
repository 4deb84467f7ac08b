"""The one mp4 writer: MPEG-4 part 2 (mp4v) through OpenCV, encoded on a helper thread, frame count checked.

OpenCV's writer only warns when a frame cannot be written (a full disk), so :meth:`Mp4Writer.close`
reads the file's frame count back and raises OSError when it is short. :func:`write_mp4` adds the
temporary-file-then-rename step for callers that publish a single file.
"""

from __future__ import annotations

import errno
import os
import queue
import threading
from collections.abc import Iterable
from pathlib import Path
from typing import Self

import cv2
import numpy as np

from motioncore.files import atomic_output


def quiet_video_logs() -> None:
    """Keep FFmpeg's and OpenCV's own log lines ("moov atom not found", ...) off stderr: every failure they
    log is one we report in our one line (a video that does not open, a short file). Takes effect when OpenCV
    first opens a video in the process, and in child processes started later; a user's own
    ``OPENCV_FFMPEG_LOGLEVEL`` / ``OPENCV_LOG_LEVEL`` (to debug a video) is kept."""
    os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")  # AV_LOG_QUIET
    if "OPENCV_LOG_LEVEL" not in os.environ:
        cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_SILENT)


quiet_video_logs()  # every mp4 this module writes or checks


class Mp4Writer:
    """Frames ``(H, W, 3)`` uint8 BGR of size ``size = (W, H)`` to the mp4 at ``path`` at ``fps``; the
    encoding runs on a helper thread (at most ``depth`` frames queued), overlapping the caller's drawing.

    Use as a context manager, or call :meth:`close` (``abort=True`` on failure: nothing is checked)."""

    def __init__(self, path: str | os.PathLike, fps: float, size: tuple[int, int], depth: int = 4, name: str | None = None):
        if not fps > 0:
            raise ValueError(f"expected fps > 0, got {fps}")
        self.path, self.size, self.written = os.fspath(path), (int(size[0]), int(size[1])), 0
        self.name = name or self.path  # what errors call the file (the final name, not the temporary one)
        self.writer = cv2.VideoWriter(self.path, cv2.VideoWriter_fourcc(*"mp4v"), float(fps), self.size)
        if not self.writer.isOpened():
            raise ValueError(f"{self.name}: OpenCV cannot open an mp4v video writer")
        self.frames: queue.Queue = queue.Queue(maxsize=depth)
        self.error: BaseException | None = None
        self.thread = threading.Thread(target=self._run, name="mp4-encoder", daemon=True)
        self.thread.start()

    def _run(self) -> None:
        while (frame := self.frames.get()) is not None:
            if self.error is None:
                try:
                    self.writer.write(frame)
                except Exception as exc:  # noqa: BLE001 - raised again by write() or close()
                    self.error = exc

    def write(self, frame: np.ndarray) -> None:
        if frame.shape != (self.size[1], self.size[0], 3) or frame.dtype != np.uint8:
            raise ValueError(f"{self.name}: expected a {self.size[1]}x{self.size[0]}x3 uint8 frame, got "
                             f"{'x'.join(map(str, frame.shape))} {frame.dtype}")
        if self.error is not None:
            raise self.error
        self.frames.put(frame)
        self.written += 1

    def close(self, abort: bool = False) -> int:
        """Finish the file; returns the number of frames. Raises what encoding raised, or OSError when the
        file holds fewer frames than were written (unless ``abort``)."""
        self.frames.put(None)
        self.thread.join()
        self.writer.release()
        if not abort:
            if self.error is not None:
                raise self.error
            check_frame_count(self.path, self.written, self.name)
        return self.written

    def __enter__(self) -> Self:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        self.close(abort=exc_type is not None)


def check_frame_count(path: str | os.PathLike, frames: int, name: str | os.PathLike | None = None) -> None:
    """Raise OSError naming ``name`` (default ``path``) unless the video at ``path`` holds ``frames`` frames."""
    cap = cv2.VideoCapture(os.fspath(path))
    got = int(cap.get(cv2.CAP_PROP_FRAME_COUNT)) if cap.isOpened() else 0
    cap.release()
    if got < frames:
        raise OSError(errno.EIO, f"the video was not written completely ({got} of {frames} frames; is the disk full?)",
                      os.fspath(name if name is not None else path))


def write_mp4(frames: Iterable[np.ndarray], path: str | os.PathLike, fps: float, size: tuple[int, int]) -> Path:
    """Write ``frames`` (see :class:`Mp4Writer`) to ``path`` through a temporary file renamed at the end,
    so a failure leaves no partial video; returns the path."""
    out = Path(path)
    with atomic_output(out, out.suffix or ".mp4") as tmp, Mp4Writer(tmp, fps, size, name=out) as writer:
        for frame in frames:
            writer.write(frame)
    return out
