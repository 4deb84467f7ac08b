"""BlazePose landmark model (full): crop, inference, decoding, heatmap refinement.

Mirrors MediaPipe's pose_landmark_by_roi graph. The model predicts 39 points:
the 33 pose landmarks (:data:`POSE_LANDMARKS`) and auxiliary points, of which
33 (hip centre) and 34 (full-body size/rotation point) give the next ROI.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import onnxruntime as ort

from lifting.blazepose.geometry import Roi, crop, crop_to_image, rotate_xy

INPUT_SIZE = 256
NUM_POINTS = 39
NUM_LANDMARKS = 33
HEATMAP_KERNEL = 7
MIN_REFINE_CONFIDENCE = 0.5

POSE_LANDMARKS = (
    "nose", "left_eye_inner", "left_eye", "left_eye_outer", "right_eye_inner", "right_eye",
    "right_eye_outer", "left_ear", "right_ear", "mouth_left", "mouth_right", "left_shoulder",
    "right_shoulder", "left_elbow", "right_elbow", "left_wrist", "right_wrist", "left_pinky",
    "right_pinky", "left_index", "right_index", "left_thumb", "right_thumb", "left_hip",
    "right_hip", "left_knee", "right_knee", "left_ankle", "right_ankle", "left_heel",
    "right_heel", "left_foot_index", "right_foot_index",
)  # fmt: skip


@dataclass
class LandmarkOutput:
    """Model output for one ROI, MediaPipe's frame (x right, y down, z away from camera).

    ``score`` pose flag in [0,1]; ``image`` (39,3): x, y image pixels and z in
    pixels at the same scale (smaller = closer to camera); ``world`` (39,3)
    metres, hip-centred, rotated back by the ROI rotation; ``visibility`` and
    ``presence`` (39,) probabilities.
    """

    score: float
    image: np.ndarray
    world: np.ndarray
    visibility: np.ndarray
    presence: np.ndarray


def sigmoid(x: np.ndarray) -> np.ndarray:
    return 1.0 / (1.0 + np.exp(-x))


def refine_with_heatmap(
    xy: np.ndarray,
    heatmap: np.ndarray,
    kernel_size: int = HEATMAP_KERNEL,
    min_confidence: float = MIN_REFINE_CONFIDENCE,
) -> np.ndarray:
    """MediaPipe's RefineLandmarksFromHeatmap.

    ``xy`` (K,2) normalized crop coordinates, ``heatmap`` (H,W,K) logits.
    Each point inside the heatmap becomes the sigmoid-weighted mean of the
    cell indices in a ``kernel_size`` window around it, divided by W (H), when
    the window's peak confidence reaches ``min_confidence``. Returns (K,2).
    """
    hm_h, hm_w, channels = heatmap.shape
    if xy.shape != (channels, 2):
        raise ValueError(f"expected xy of shape ({channels}, 2), got {xy.shape}")
    out = np.array(xy, dtype=float, copy=True)
    offset = (kernel_size - 1) // 2
    for k in range(channels):
        col, row = int(xy[k, 0] * hm_w), int(xy[k, 1] * hm_h)  # truncation, as in C++
        if not (0 <= col < hm_w and 0 <= row < hm_h):
            continue
        r0, r1 = max(0, row - offset), min(hm_h, row + offset + 1)
        c0, c1 = max(0, col - offset), min(hm_w, col + offset + 1)
        conf = sigmoid(heatmap[r0:r1, c0:c1, k].astype(np.float64))
        total = conf.sum()
        if conf.max() >= min_confidence and total > 0:
            rows, cols = np.mgrid[r0:r1, c0:c1]
            out[k] = ((cols * conf).sum() / hm_w / total, (rows * conf).sum() / hm_h / total)
    return out


class LandmarkModel:
    """Runs the landmark model on an ROI of an RGB frame."""

    def __init__(self, session: ort.InferenceSession):
        self.session = session
        self._input = session.get_inputs()[0].name

    def run(self, frame_rgb: np.ndarray, roi: Roi) -> LandmarkOutput:
        """Landmarks of the person in ``roi`` of ``frame_rgb`` (H,W,3) uint8."""
        tensor = crop(frame_rgb, roi, INPUT_SIZE).astype(np.float32) * (1.0 / 255.0)
        raw, flag, heatmap, world = self.session.run(
            ["Identity", "Identity_1", "Identity_3", "Identity_4"], {self._input: tensor[None]}
        )
        return decode_landmarks(raw[0], float(flag.reshape(-1)[0]), heatmap[0], world[0], roi)


def decode_landmarks(raw: np.ndarray, flag: float, heatmap: np.ndarray, world: np.ndarray, roi: Roi) -> LandmarkOutput:
    """Model tensors → :class:`LandmarkOutput` in image coordinates.

    ``raw`` (195,) = 39 × (x, y, z, visibility logit, presence logit) in crop
    pixels; ``heatmap`` (64,64,39); ``world`` (117,) = 39 × 3 metres.
    """
    pts = raw.reshape(NUM_POINTS, 5).astype(np.float64)
    xy = refine_with_heatmap(pts[:, :2] / INPUT_SIZE, heatmap)
    image = np.empty((NUM_POINTS, 3))
    image[:, :2] = crop_to_image(xy * INPUT_SIZE, roi, INPUT_SIZE)
    image[:, 2] = pts[:, 2] / INPUT_SIZE * roi.size
    world_pts = rotate_xy(world.reshape(NUM_POINTS, 3).astype(np.float64), roi.rotation)
    return LandmarkOutput(
        score=flag,
        image=image,
        world=world_pts,
        visibility=sigmoid(pts[:, 3]),
        presence=sigmoid(pts[:, 4]),
    )
