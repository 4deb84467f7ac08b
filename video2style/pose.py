"""``video2style pose``: a video of one person -> a BVH on the canonical skeleton (+ a preview).

The BVH keeps the video's frame rate and covers the frames where the person was tracked
(see :mod:`lifting.lift`). The preview shows each video frame with the BlazePose
landmarks drawn on it beside the fitted 3-D skeleton; its frames are decoded again one at a
time, never held in memory. Both files are written to temporary names and renamed at the
end, so a failure leaves neither.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from lifting.blazepose.results import POSE_CONNECTIONS
from lifting.camera import DEFAULT_FOV_DEG
from lifting.filtering import DEFAULT_CUTOFF_HZ
from lifting.lift import lift_video
from lifting.tracking import FrameProgress, Progress
from motioncore.files import publish, temp_beside

if TYPE_CHECKING:
    from lifting.blazepose.tracker import PoseTracker
    from lifting.reconstruct import LiftResult

PREVIEW_HEIGHT = 480
_LEFT, _RIGHT, _MID = (40, 40, 215), (200, 120, 20), (40, 200, 40)  # BGR, as motioncore.render


def pose_file(
    video: Path,
    out_bvh: Path,
    preview: Path | None = None,
    cutoff_hz: float | None = DEFAULT_CUTOFF_HZ,
    progress: Progress = True,
    *,
    fov_deg: float = DEFAULT_FOV_DEG,
    trajectory: str = "auto",
    tracker: PoseTracker | None = None,
    span: tuple[float | None, float | None] = (None, None),
    rotate: int | None = None,
) -> dict:
    """Lift ``video`` to ``out_bvh`` (canonical skeleton, centimetres, the video's fps) and, if
    ``preview`` is given, write an mp4 of landmarks beside the fitted skeleton.

    ``span``: ``(start, end)`` seconds of the video to lift (None: open end). ``rotate``: degrees
    clockwise to turn the frames before tracking (None: none, and a video whose person is upside down or on
    their side is refused naming ``--rotate``; see :func:`lifting.lift.lift_video`).
    ``progress``: True for bars in frames, a callable taking a line, or None/False. Returns a
    summary dict (frames, tracked span, timings, frames per second, paths). Raises ValueError
    with a one-line message naming the file for unusable videos; nothing is written then.
    """
    video, out_bvh = Path(video), Path(out_bvh)
    t0 = time.perf_counter()
    lifted = lift_video(video, progress, cutoff_hz, tracker=tracker, span=span, rotate=rotate, fov_deg=fov_deg,
                        trajectory=trajectory)
    t1 = time.perf_counter()
    tmp_preview = None
    try:
        if preview is not None:
            tmp_preview = _write_preview(video, lifted, Path(preview), progress, rotate or 0)
        t2 = time.perf_counter()
        from motioncore.bvh import (  # torch: imported while tracking
            BvhLayout,
            write_bvh,
        )
        from motioncore.skeleton import CANONICAL

        write_bvh(out_bvh, lifted.motion, BvhLayout.default(CANONICAL.skeleton, scale=0.01))
        if tmp_preview is not None:
            try:
                publish(tmp_preview, preview)
            except OSError:
                out_bvh.unlink(missing_ok=True)  # all or nothing
                raise
            tmp_preview = None
    finally:
        if tmp_preview is not None:
            Path(tmp_preview).unlink(missing_ok=True)
    t3 = time.perf_counter()
    info = lifted.info
    n = info["frames"]
    return {
        "video": str(video),
        "bvh": str(out_bvh),
        "preview": None if preview is None else str(preview),
        "frames": n,
        "video_fps": info["fps"],
        "tracked_frames": int(info["found"]),
        "span": (lifted.start, lifted.stop),
        "bvh_frames": lifted.motion.num_frames,
        "bvh_seconds": lifted.motion.duration,
        "bvh_fps": lifted.motion.fps,
        "filled_frames": lifted.filled,
        "trajectory": info["trajectory"],
        "moving_ground": info["moving_ground"],
        "contact_fraction": info["contact_fraction"],
        "distance_m": info["distance_m"],
        "camera_tilt_deg": info["camera_tilt_deg"],
        "cutoff_hz": info["cutoff_hz"],
        "seconds": t3 - t0,
        "track_seconds": info.get("track_s", t1 - t0),
        "fit_seconds": info.get("lift_s", 0.0),
        "preview_seconds": (t2 - t1) if preview is not None else 0.0,
        "fps": n / (t3 - t0),
    }


def _draw_landmarks(img: np.ndarray, pts: np.ndarray, scale: float, faded: bool) -> None:
    """BlazePose's skeleton ``pts (33, 2)`` (pixels of the original frame) onto ``img`` in place."""
    import cv2

    p = np.round(pts * scale * 16).astype(np.int64)
    thick = max(2, img.shape[0] // 200)
    for a, b in POSE_CONNECTIONS:
        side = _LEFT if a % 2 and b % 2 and a > 10 else _RIGHT if a % 2 == 0 and b % 2 == 0 and a > 10 else _MID
        colour = tuple(int(c * 0.5 + 64) for c in side) if faded else side
        cv2.line(img, tuple(map(int, p[a])), tuple(map(int, p[b])), colour, thick, cv2.LINE_AA, 4)
    for k in range(11, 33):
        cv2.circle(img, tuple(map(int, p[k])), int((thick + 1) * 16), (255, 255, 255), -1, cv2.LINE_AA, 4)


def _frames(video: Path, n: int, first: int = 0, rotate: int = 0):
    """``(index - first, frame)`` of ``n`` frames from frame ``first`` on, turned ``rotate`` degrees clockwise."""
    from lifting.video import iter_frames

    for i, _, frame in iter_frames(video, rotate):
        if i < first:
            continue
        if i - first >= n:
            break
        yield i - first, frame


def _write_preview(video: Path, lifted: LiftResult, out: Path, progress: Progress, rotate: int = 0) -> str:
    """Render the preview to a temporary file beside ``out``; returns its path (the caller renames)."""
    import cv2  # OpenCV and the torch side only for a preview (pose_file's own work is done by now)

    from lifting.video import prefetched
    from motioncore.mp4 import Mp4Writer
    from motioncore.render import Panel, render_frame
    from motioncore.skeleton import CANONICAL

    tr = lifted.track
    height = PREVIEW_HEIGHT
    scale = height / tr.height
    width = round(tr.width * scale / 2) * 2
    n = len(tr.found)
    sk = CANONICAL.skeleton
    positions = np.full((n, sk.num_joints, 3), np.nan, np.float32)
    positions[lifted.start:lifted.stop] = lifted.motion.global_positions().numpy()
    panel = Panel(positions, sk.parents, "fitted skeleton", names=sk.names)
    tmp = str(temp_beside(out, ".mp4"))
    size = (width + height, height)
    writer = None
    bar = FrameProgress(progress, n, f"{out.name}: preview")
    try:
        writer = Mp4Writer(tmp, float(tr.fps), size, name=out)
        first = round(float(tr.times[0]) * tr.fps) if len(tr.times) else 0  # the span's first frame (--start)
        for i, frame in prefetched(_frames(video, n, first, rotate)):  # decoding overlaps the drawing
            left = cv2.resize(frame, (width, height), interpolation=cv2.INTER_LINEAR)
            inside = lifted.start <= i < lifted.stop
            if np.isfinite(tr.image[i]).all():
                _draw_landmarks(left, tr.image[i, :, :2], scale, faded=not inside)
            label = "BlazePose" if tr.found[i] else ("no person (interpolated)" if inside else "no person")
            cv2.putText(left, label, (8, 26), cv2.FONT_HERSHEY_SIMPLEX, 0.7, (255, 255, 255), 3, cv2.LINE_AA)
            cv2.putText(left, label, (8, 26), cv2.FONT_HERSHEY_SIMPLEX, 0.7, (20, 20, 20), 1, cv2.LINE_AA)
            right = render_frame([panel], i, (height, height), tr.fps)
            writer.write(np.concatenate([left, right], axis=1))
            bar.update()
        writer.close()
    except BaseException:
        if writer is not None:
            writer.close(abort=True)
        bar.close()
        Path(tmp).unlink(missing_ok=True)
        raise
    bar.close()
    return tmp
