"""BlazePose landmark model (full): crop, inference, decoding, heatmap refinement.

Mirrors MediaPipe's pose_landmark_by_roi graph. The model predicts 39 points:
the 33 pose landmarks (:data:`lifting.blazepose.results.POSE_LANDMARKS`) and auxiliary points, of which
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
    col, row = (xy[:, 0] * hm_w).astype(int), (xy[:, 1] * hm_h).astype(int)  # truncation, as in C++
    step = np.arange(-offset, offset + 1)
    rows, cols = row[:, None] + step, col[:, None] + step  # (K, S) window cells, some outside
    logits = heatmap[np.clip(rows, 0, hm_h - 1)[:, :, None], np.clip(cols, 0, hm_w - 1)[:, None, :],
                     np.arange(channels)[:, None, None]]  # (K, S, S)
    inside = ((rows >= 0) & (rows < hm_h))[:, :, None] & ((cols >= 0) & (cols < hm_w))[:, None, :]
    conf = np.where(inside, sigmoid(logits.astype(np.float64)), 0.0)
    total = conf.sum(axis=(1, 2))
    use = (0 <= col) & (col < hm_w) & (0 <= row) & (row < hm_h) & (conf.max(axis=(1, 2)) >= min_confidence) & (total > 0)
    if use.any():
        conf, total = conf[use], total[use]
        x = (conf * cols[use][:, None, :]).sum(axis=(1, 2)) / hm_w / total
        y = (conf * rows[use][:, :, None]).sum(axis=(1, 2)) / hm_h / total
        out[use] = np.stack([x, y], axis=-1)
    return out


# The landmark graph's outputs read here: landmarks, presence flag, heatmap, world landmarks. Its
# fifth, the 256x256 segmentation mask (Identity_2), is cut from the converted model (assets.py).
OUTPUTS = ("Identity", "Identity_1", "Identity_3", "Identity_4")


class LandmarkModel:
    """Runs the landmark model on an ROI of an RGB frame."""

    def __init__(self, session: ort.InferenceSession):
        self.session = session
        self._input = session.get_inputs()[0].name

    def run(self, frame_rgb: np.ndarray, roi: Roi) -> LandmarkOutput:
        """Landmarks of the person in ``roi`` of ``frame_rgb`` (H,W,3) uint8."""
        tensor = crop(frame_rgb, roi, INPUT_SIZE).astype(np.float32) * (1.0 / 255.0)
        raw, flag, heatmap, world = self.session.run(list(OUTPUTS), {self._input: tensor[None]})
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
