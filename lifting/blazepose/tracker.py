"""Per-frame BlazePose tracking over a video (MediaPipe's pose_landmark_cpu logic).

The detector runs on the first frame and whenever the person is lost; in
between, the crop for frame t comes from the auxiliary landmarks of frame
t−1 (hip centre and full-body point → rotated square ×1.25), smoothed with a
one-euro filter because small crop shifts move the world landmarks by
centimetres. When tracking fails, the detector is re-run on the same frame.

Output coordinate frames:

* ``world``: metres, origin between the hips, **Y up**: x to the image's
  right, y up, z toward the camera (right-handed). BlazePose's own world
  frame is x right, y down, z away from the camera; we return (x, −y, −z),
  a 180° rotation about x. The ROI rotation is undone first, so "up" is the
  image's up, not the person's.
* ``image``: x, y in pixels of the original frame; z in pixels at the same
  scale, relative to the hips, MediaPipe's sign (smaller = closer to camera).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from lifting.blazepose.assets import ensure_models
from lifting.blazepose.detector import Detection, PoseDetector
from lifting.blazepose.filters import OneEuroFilter
from lifting.blazepose.geometry import Roi, roi_from_alignment_points
from lifting.blazepose.landmarks import NUM_LANDMARKS, LandmarkModel, LandmarkOutput
from lifting.blazepose.runtime import DEFAULT_THREADS, make_session

_HIP_CENTRE, _BODY_POINT = 33, 34  # auxiliary landmark indices
_MP_TO_Y_UP = np.array([1.0, -1.0, -1.0])
GATE_RADIUS = 0.75  # re-acquisition radius right after a loss, in typical crop sizes
GATE_GROWTH = 0.75  # its growth, crop sizes per second of loss


@dataclass
class PoseFrame:
    """Result for one frame. Arrays are NaN when ``found`` is False.

    ``world`` (33,3) metres, hip-centred, Y up (see module doc); ``image``
    (33,3) pixels; ``visibility``, ``presence`` (33,) in [0,1]; ``score`` pose
    flag of the landmark model (0 when it did not run); ``roi`` the crop used;
    ``detected`` whether the detector ran on this frame.
    """

    world: np.ndarray
    image: np.ndarray
    visibility: np.ndarray
    presence: np.ndarray
    score: float
    found: bool
    roi: Roi | None = None
    detected: bool = False

    @classmethod
    def missing(cls, score: float = 0.0, detected: bool = False) -> PoseFrame:
        nan3 = np.full((NUM_LANDMARKS, 3), np.nan)
        nan1 = np.full(NUM_LANDMARKS, np.nan)
        return cls(nan3, nan3.copy(), nan1, nan1.copy(), score, False, None, detected)


class PoseTracker:
    """Detector + landmark model with ROI tracking; follows one main person.

    Detection (first frame, or when the landmark model's pose flag drops):
    whole frame, then tiles if empty (:meth:`PoseDetector.search`); the chosen
    person is re-detected in a zoomed window (:meth:`PoseDetector.refine`) for
    better keypoints, and the landmark model tries the zoomed then the plain ROI.

    ``models``: dict from :func:`ensure_models` (made on demand when None).
    A person counts as found when the landmark model's pose flag is at least
    ``min_pose_score``; detections need ``min_detection_score``.

    Main person: at the start (and after ``forget_s`` seconds without the
    person) the largest detection is chosen. After a shorter loss, the
    detection nearest the last crop is taken, but only within a radius of
    (GATE_RADIUS + GATE_GROWTH · seconds since loss) typical crop sizes, so
    that a bystander elsewhere in the frame is not picked up meanwhile
    (:func:`choose_detection`).
    """

    def __init__(
        self,
        models: dict[str, Path] | None = None,
        *,
        cache_dir: str | Path | None = None,
        num_threads: int = DEFAULT_THREADS,
        min_detection_score: float = 0.5,
        min_pose_score: float = 0.5,
        smooth_roi: bool = True,
        forget_s: float = 3.0,
    ):
        models = models if models is not None else ensure_models(cache_dir)
        self.detector = PoseDetector(make_session(models["pose_detection"], num_threads), min_detection_score)
        self.landmarks = LandmarkModel(make_session(models["pose_landmark_full"], num_threads))
        self.min_pose_score = min_pose_score
        self.smooth_roi = smooth_roi
        self.forget_s = forget_s
        self._filter = OneEuroFilter()
        self.reset()

    def reset(self) -> None:
        """Forget the tracked person (call between unrelated videos)."""
        self._roi: Roi | None = None  # crop for the next frame
        self._recent: deque[Roi] = deque(maxlen=30)  # crops of the last frames with the person
        self._last_seen: float | None = None
        self._frame_count = 0
        self._filter.reset()

    def process(self, frame_bgr: np.ndarray, time_s: float | None = None) -> PoseFrame:
        """Track the person in one frame (H,W,3) uint8 BGR at ``time_s`` seconds."""
        if frame_bgr.ndim != 3 or frame_bgr.shape[2] != 3 or frame_bgr.dtype != np.uint8:
            raise ValueError(f"expected an (H,W,3) uint8 BGR frame, got {frame_bgr.shape} {frame_bgr.dtype}")
        time_s = self._frame_count / 30.0 if time_s is None else float(time_s)
        self._frame_count += 1
        rgb = cv2.cvtColor(frame_bgr, cv2.COLOR_BGR2RGB)

        roi, out, detected, score = self._roi, None, False, 0.0
        if roi is not None:
            out = self.landmarks.run(rgb, roi)
            score = out.score
            if out.score < self.min_pose_score:
                out = None
        if out is None:
            self._filter.reset()  # a new crop from detection must not be pulled toward the old one
            detected = True
            for roi in self._detect(rgb, time_s):
                candidate = self.landmarks.run(rgb, roi)
                score = max(score, candidate.score)
                if candidate.score >= self.min_pose_score:
                    out = candidate
                    break
        if out is None:
            self._roi = None
            return PoseFrame.missing(score, detected)

        self._roi = self._next_roi(out, time_s)
        self._recent.append(roi)
        self._last_seen = time_s
        return PoseFrame(
            world=out.world[:NUM_LANDMARKS] * _MP_TO_Y_UP,
            image=out.image[:NUM_LANDMARKS],
            visibility=out.visibility[:NUM_LANDMARKS],
            presence=out.presence[:NUM_LANDMARKS],
            score=out.score,
            found=True,
            roi=roi,
            detected=detected,
        )

    def _next_roi(self, out: LandmarkOutput, time_s: float) -> Roi:
        aux = out.image[[_HIP_CENTRE, _BODY_POINT], :2]
        if self.smooth_roi:
            extent = aux.max(axis=0) - aux.min(axis=0)
            object_scale = float(extent.mean())
            if object_scale > 1e-6:
                aux = self._filter(aux, time_s, 1.0 / object_scale)
        return roi_from_alignment_points(aux[0], aux[1])

    def _detect(self, rgb: np.ndarray, time_s: float) -> list[Roi]:
        """Candidate crops for the main person: from the zoomed re-detection, then the plain one."""
        detection = self._choose(self.detector.search(rgb), time_s)
        if detection is None:
            return []
        refined = self.detector.refine(rgb, detection)
        return ([refined.roi()] if refined is not None else []) + [detection.roi()]

    def _choose(self, detections: list[Detection], time_s: float) -> Detection | None:
        since = None if self._last_seen is None else time_s - self._last_seen
        return choose_detection(detections, list(self._recent), since, self.forget_s)


def choose_detection(
    detections: list[Detection], recent: list[Roi], seconds_since_seen: float | None, forget_s: float = 3.0
) -> Detection | None:
    """Pick the main person (see :class:`PoseTracker`).

    ``recent``: crops of the last frames where the person was found (oldest
    first); ``seconds_since_seen``: time since the last of them, None if never.
    Returns None when no detection qualifies.
    """
    if not detections:
        return None
    rois = [d.roi() for d in detections]
    if seconds_since_seen is None or not recent or seconds_since_seen > forget_s:
        return detections[int(np.argmax([r.size for r in rois]))]
    typical = float(np.median([r.size for r in recent]))
    distance = np.array([np.linalg.norm(r.center - recent[-1].center) for r in rois]) / typical
    radius = GATE_RADIUS + GATE_GROWTH * seconds_since_seen
    best = int(np.argmin(distance))
    return detections[best] if distance[best] <= radius else None
