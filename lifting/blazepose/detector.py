"""BlazePose person detector: letterboxed 224×224 input, SSD anchors, weighted NMS.

Mirrors MediaPipe's pose_detection_cpu graph. Each detection carries a face
box and 4 keypoints: 0 hip centre, 1 full-body size/rotation point,
2 shoulder centre, 3 upper-body size/rotation point.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import onnxruntime as ort

from lifting.blazepose.geometry import (
    Roi,
    crop,
    crop_to_image,
    letterbox_roi,
    roi_from_alignment_points,
)

INPUT_SIZE = 224
NUM_ANCHORS = 2254
_STRIDES = (8, 16, 32, 32, 32)
_ANCHORS_PER_LAYER = 2  # aspect ratio 1.0 plus the interpolated scale


@dataclass(frozen=True)
class Detection:
    """One detected person in image pixels: ``score`` in (0,1), ``box`` (4,) xmin, ymin,
    xmax, ymax of the face, ``keypoints`` (4,2)."""

    score: float
    box: np.ndarray
    keypoints: np.ndarray

    def roi(self) -> Roi:
        """Crop for the landmark model: hip centre + full-body point, ×1.25, square."""
        return roi_from_alignment_points(self.keypoints[0], self.keypoints[1])


def ssd_anchors() -> np.ndarray:
    """Anchor centres (2254,2) in [0,1], MediaPipe SsdAnchorsCalculator order.

    Layers with equal strides share one feature map (28², 14², 7² cells), cells
    row-major, all anchors of a cell together; fixed anchor size 1.
    """
    centres = []
    layer = 0
    while layer < len(_STRIDES):
        last = layer
        while last < len(_STRIDES) and _STRIDES[last] == _STRIDES[layer]:
            last += 1
        per_cell = _ANCHORS_PER_LAYER * (last - layer)
        cells = math.ceil(INPUT_SIZE / _STRIDES[layer])
        ys, xs = np.meshgrid(np.arange(cells), np.arange(cells), indexing="ij")
        grid = np.stack([(xs.ravel() + 0.5) / cells, (ys.ravel() + 0.5) / cells], axis=1)
        centres.append(np.repeat(grid, per_cell, axis=0))
        layer = last
    anchors = np.concatenate(centres)
    assert anchors.shape == (NUM_ANCHORS, 2)
    return anchors


_ANCHORS = ssd_anchors()


def decode(raw_boxes: np.ndarray, raw_scores: np.ndarray, anchors: np.ndarray = _ANCHORS):
    """Raw model outputs → (scores (N,), boxes (N,4) xmin,ymin,xmax,ymax, keypoints (N,4,2)).

    ``raw_boxes`` (N,12): x, y, w, h, then 4 keypoint (x, y), in 224-pixel
    offsets from the anchor; ``raw_scores`` (N,) logits, clipped to ±100.
    Coordinates come out normalized to the 224×224 input.
    """
    raw_boxes = raw_boxes.reshape(-1, 12).astype(np.float64) / INPUT_SIZE
    scores = 1.0 / (1.0 + np.exp(-np.clip(raw_scores.reshape(-1).astype(np.float64), -100, 100)))
    centre = raw_boxes[:, 0:2] + anchors
    half = raw_boxes[:, 2:4] / 2
    boxes = np.concatenate([centre - half, centre + half], axis=1)
    keypoints = raw_boxes[:, 4:12].reshape(-1, 4, 2) + anchors[:, None, :]
    return scores, boxes, keypoints


def iou(box: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    """IoU of one box (4,) with boxes (N,4), all xmin, ymin, xmax, ymax."""
    lo = np.maximum(box[:2], boxes[:, :2])
    hi = np.minimum(box[2:], boxes[:, 2:])
    inter = np.prod(np.clip(hi - lo, 0, None), axis=1)
    area = np.prod(box[2:] - box[:2])
    areas = np.prod(boxes[:, 2:] - boxes[:, :2], axis=1)
    union = area + areas - inter
    return np.where(union > 0, inter / np.where(union > 0, union, 1), 0.0)


def weighted_nms(scores, boxes, keypoints, min_score: float, iou_threshold: float = 0.3):
    """MediaPipe's WEIGHTED non-max suppression.

    Candidates above ``min_score`` are taken in descending score; each keeps
    the top score and the score-weighted mean box/keypoints of all remaining
    candidates overlapping it by IoU > ``iou_threshold``. Returns a list of
    (score, box (4,), keypoints (4,2)).
    """
    order = np.flatnonzero(scores >= min_score)
    order = order[np.argsort(-scores[order], kind="stable")]
    results = []
    while len(order):
        top = order[0]
        overlap = iou(boxes[top], boxes[order]) > iou_threshold
        overlap[0] = True
        group, order = order[overlap], order[~overlap]
        w = scores[group][:, None]
        box = (boxes[group] * w).sum(0) / w.sum()
        kps = (keypoints[group] * w[:, :, None]).sum(0) / w.sum()
        results.append((float(scores[top]), box, kps))
    return results


def merge_detections(detections: list[Detection], min_separation: float = 0.5) -> list[Detection]:
    """Drop duplicates (from overlapping tiles): a detection whose hip keypoint lies
    within ``min_separation`` × ROI size of a better one is removed. Best first."""
    kept: list[Detection] = []
    for det in sorted(detections, key=lambda d: -d.score):
        roi = det.roi()
        if all(
            np.linalg.norm(det.keypoints[0] - k.keypoints[0]) > min_separation * max(roi.size, k.roi().size)
            for k in kept
        ):
            kept.append(det)
    return kept


class PoseDetector:
    """Runs the detector model on RGB frames (H,W,3) uint8; results in frame pixels.

    Beyond MediaPipe's single whole-frame pass, :meth:`search` looks in square
    tiles when the whole frame gives nothing, and :meth:`refine` re-detects in a
    zoomed window: BlazePose's keypoints are poor for people filling only a
    small part of the 224×224 input.
    """

    def __init__(self, session: ort.InferenceSession, min_score: float = 0.5):
        self.session = session
        self.min_score = min_score
        self._input = session.get_inputs()[0].name
        self.runs = 0  # model invocations, for statistics

    def detect(self, frame_rgb: np.ndarray, roi: Roi | None = None) -> list[Detection]:
        """Detections inside square ``roi`` (default: whole frame, letterboxed), best first."""
        h, w = frame_rgb.shape[:2]
        roi = roi if roi is not None else letterbox_roi(w, h)
        tensor = crop(frame_rgb, roi, INPUT_SIZE, border="zero").astype(np.float32) * (2.0 / 255.0) - 1.0
        raw_boxes, raw_scores = self.session.run(["Identity", "Identity_1"], {self._input: tensor[None]})
        self.runs += 1
        scores, boxes, keypoints = decode(raw_boxes[0], raw_scores[0])
        detections = []
        for score, box, kps in weighted_nms(scores, boxes, keypoints, self.min_score):
            corners = crop_to_image(box.reshape(2, 2) * INPUT_SIZE, roi, INPUT_SIZE).reshape(4)
            detections.append(Detection(score, corners, crop_to_image(kps * INPUT_SIZE, roi, INPUT_SIZE)))
        return detections

    def search(self, frame_rgb: np.ndarray, min_aspect_for_tiles: float = 1.2) -> list[Detection]:
        """Whole frame first; if nobody is found in a wide or tall frame, square tiles of the
        short side's size, overlapping by at least a quarter, along the long side."""
        detections = self.detect(frame_rgb)
        h, w = frame_rgb.shape[:2]
        short, long = min(w, h), max(w, h)
        if detections or long < min_aspect_for_tiles * short:
            return detections
        n = math.ceil(long / (0.75 * short))
        for centre in np.linspace(short / 2, long - short / 2, n):
            cx, cy = (centre, h / 2) if w >= h else (w / 2, centre)
            detections += self.detect(frame_rgb, Roi(float(cx), float(cy), float(short)))
        return merge_detections(detections)

    def refine(self, frame_rgb: np.ndarray, detection: Detection, zoom: float = 1.5) -> Detection | None:
        """Re-detect in a square window around ``detection`` (hip centre, side = ``zoom`` ×
        max(ROI size, box size)). Returns the re-detection nearest the original hips if
        they are within half the window of them, else None (also when the window would
        not magnify the frame)."""
        box_size = float(np.max(detection.box[2:] - detection.box[:2]))
        side = zoom * max(detection.roi().size, box_size)
        if side >= 0.9 * max(frame_rgb.shape[:2]):
            return None
        hips = detection.keypoints[0]
        found = self.detect(frame_rgb, Roi(float(hips[0]), float(hips[1]), side))
        shifts = [float(np.linalg.norm(d.keypoints[0] - hips)) for d in found]
        if not found or min(shifts) > side / 2:
            return None
        return found[int(np.argmin(shifts))]
