"""Streaming access to video files through OpenCV (one frame in memory at a time)."""

from __future__ import annotations

import math
import queue
import threading
import warnings
from collections.abc import Iterator
from pathlib import Path

import cv2
import numpy as np

from lifting.upright import check_rotation

DEFAULT_FPS = 30.0
_CV_ROTATE = {90: cv2.ROTATE_90_CLOCKWISE, 180: cv2.ROTATE_180, 270: cv2.ROTATE_90_COUNTERCLOCKWISE}


def rotate_frame(frame: np.ndarray, rotate: int) -> np.ndarray:
    """``frame (H,W,C)`` turned ``rotate`` degrees clockwise (one of :data:`lifting.upright.ROTATIONS`)."""
    return frame if not rotate else cv2.rotate(frame, _CV_ROTATE[rotate])


def _open(path: str | Path) -> tuple[Path, cv2.VideoCapture]:
    from motioncore.mp4 import quiet_video_logs

    path = Path(path)
    if path.is_dir():
        raise ValueError(f"{path}: is a folder, not a video file")
    if not path.is_file():
        raise ValueError(f"video file not found: {path}")
    quiet_video_logs()  # FFmpeg's "moov atom not found" and the like: our one line says it
    cap = cv2.VideoCapture(str(path))
    if not cap.isOpened():
        cap.release()
        raise ValueError(f"cannot open as a video (not a video or unsupported codec): {path}")
    cap.set(cv2.CAP_PROP_ORIENTATION_AUTO, 1)  # a phone's rotation tag is applied (OpenCV's FFmpeg default, made sure)
    return path, cap


def _fps(cap: cv2.VideoCapture, path: Path) -> float:
    fps = cap.get(cv2.CAP_PROP_FPS)
    if not fps or not math.isfinite(fps) or fps <= 0:
        warnings.warn(f"{path}: no frame rate in the file, assuming {DEFAULT_FPS} fps", stacklevel=3)
        return DEFAULT_FPS
    return float(fps)


def video_info(path: str | Path, rotate: int = 0) -> tuple[float, int, int, int]:
    """``(fps, n_frames, width, height)`` of a video file (the size of its frames as :func:`iter_frames`
    gives them: the file's rotation tag applied, then ``rotate`` degrees clockwise).

    ``n_frames`` is the container's count; when the container has none it is
    counted by decoding. Raises ``ValueError`` for a missing file, a file that
    is not a readable video, or a video without frames.
    """
    path, cap = _open(path)
    try:
        fps = _fps(cap, path)
        ok, frame = cap.read()
        if not ok or frame is None:
            raise ValueError(f"video has no readable frames: {path}")
        height, width = rotate_frame(frame, check_rotation(rotate)).shape[:2]
        n_frames = int(cap.get(cv2.CAP_PROP_FRAME_COUNT))
        if n_frames <= 0:
            n_frames = 1
            while cap.grab():
                n_frames += 1
        return fps, n_frames, width, height
    finally:
        cap.release()


def iter_frames(path: str | Path, rotate: int = 0) -> Iterator[tuple[int, float, np.ndarray]]:
    """Iterator of ``(index, time_s, frame_bgr)``, decoding one frame at a time.

    A rotation tag in the file's metadata (a phone held upright) is applied by OpenCV; ``rotate``
    (0, 90, 180, 270 degrees clockwise) then turns every frame, e.g. for a video filmed upside down.

    ``frame_bgr`` is (H,W,3) uint8 in OpenCV's BGR order; ``time_s`` =
    index / fps (constant frame rate assumed). A missing or unopenable file
    raises ``ValueError`` at the call; a video without a single readable frame
    raises it on the first ``next()``.
    """
    rotate = check_rotation(rotate)
    path, cap = _open(path)
    fps = _fps(cap, path)
    return _frames(path, cap, fps, rotate)


def _frames(path: Path, cap: cv2.VideoCapture, fps: float, rotate: int) -> Iterator[tuple[int, float, np.ndarray]]:
    try:
        index = 0
        while True:
            ok, frame = cap.read()
            if not ok or frame is None:
                break
            yield index, index / fps, rotate_frame(frame, rotate)
            index += 1
        if index == 0:
            raise ValueError(f"video has no readable frames: {path}")
    finally:
        cap.release()


def prefetched(items, depth: int = 4):
    """Iterate ``items`` (e.g. :func:`iter_frames`) with a reader thread a few items ahead, so decoding
    overlaps the work on each item; an error in the reader is raised here."""
    q: queue.Queue = queue.Queue(maxsize=depth)
    done, stop, error = object(), threading.Event(), []

    def read() -> None:
        try:
            for item in items:
                while not stop.is_set():
                    try:
                        q.put(item, timeout=0.1)
                        break
                    except queue.Full:
                        continue
                if stop.is_set():
                    return
        except BaseException as e:  # noqa: BLE001 - handed to the consumer
            error.append(e)
        finally:
            q.put(done)

    reader = threading.Thread(target=read, name="video-reader", daemon=True)
    reader.start()
    try:
        while (item := q.get()) is not done:
            yield item
        if error:
            raise error[0]
    finally:
        stop.set()
        while reader.is_alive():  # let a blocked reader finish
            try:
                q.get_nowait()
            except queue.Empty:
                reader.join(timeout=0.05)
