"""What BlazePose tracking produces, importable without onnxruntime or OpenCV (a process that only lifts
tracked landmarks, or receives them from a child process, needs no more): the 33 landmark names, their
edges, and :class:`TrackResult`, the stacked per-frame results of a video."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

POSE_LANDMARKS = (
    "nose", "left_eye_inner", "left_eye", "left_eye_outer", "right_eye_inner", "right_eye",
    "right_eye_outer", "left_ear", "right_ear", "mouth_left", "mouth_right", "left_shoulder",
    "right_shoulder", "left_elbow", "right_elbow", "left_wrist", "right_wrist", "left_pinky",
    "right_pinky", "left_index", "right_index", "left_thumb", "right_thumb", "left_hip",
    "right_hip", "left_knee", "right_knee", "left_ankle", "right_ankle", "left_heel",
    "right_heel", "left_foot_index", "right_foot_index",
)  # fmt: skip
# BlazePose's landmark graph (MediaPipe's POSE_CONNECTIONS), body part only (no face outline).
POSE_CONNECTIONS = (
    (11, 12), (11, 13), (13, 15), (15, 17), (15, 19), (17, 19), (12, 14), (14, 16), (16, 18), (16, 20),
    (18, 20), (11, 23), (12, 24), (23, 24), (23, 25), (24, 26), (25, 27), (26, 28), (27, 29), (28, 30),
    (29, 31), (30, 32), (27, 31), (28, 32), (0, 7), (0, 8),
)  # fmt: skip


@dataclass
class TrackResult:
    """Stacked per-frame results of a video: T frames.

    ``world``, ``image`` (T,33,3); ``visibility``, ``presence`` (T,33);
    ``score`` (T,); ``found`` (T,) bool mask; ``times`` (T,) seconds;
    ``fps``, ``width``, ``height`` of the video; ``detector_runs`` count.
    """

    world: np.ndarray
    image: np.ndarray
    visibility: np.ndarray
    presence: np.ndarray
    score: np.ndarray
    found: np.ndarray
    times: np.ndarray
    fps: float
    width: int
    height: int
    detector_runs: int = 0
    rois: list = field(default_factory=list, repr=False)

    @classmethod
    def stack(cls, frames: list, times: list[float], fps: float, width: int, height: int) -> TrackResult:
        """The per-frame :class:`PoseFrame` results of one video stacked into arrays."""
        return cls(
            world=np.stack([f.world for f in frames]),
            image=np.stack([f.image for f in frames]),
            visibility=np.stack([f.visibility for f in frames]),
            presence=np.stack([f.presence for f in frames]),
            score=np.array([f.score for f in frames]),
            found=np.array([f.found for f in frames], dtype=bool),
            times=np.array(times),
            fps=fps,
            width=width,
            height=height,
            detector_runs=sum(f.detected for f in frames),
            rois=[f.roi for f in frames],
        )

    @property
    def found_fraction(self) -> float:
        return float(self.found.mean()) if len(self.found) else 0.0
