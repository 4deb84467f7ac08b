"""Rotated square regions of interest (ROIs) and the crops MediaPipe feeds its models.

Conventions: image pixels, x right, y down. A :class:`Roi` rotation θ (radians)
turns the crop's axes by R(θ) = [[cos θ, -sin θ], [sin θ, cos θ]] in that
y-down frame (clockwise on screen for θ > 0), as MediaPipe's NormalizedRect.
Crop pixel (u, v) of an N×N crop maps to image point
``centre + R(θ) · ((u/N - 1/2)·size, (v/N - 1/2)·size)``: the ROI's corners
go to crop coordinates 0 and N, exactly like MediaPipe's ImageToTensor
(cv::getPerspectiveTransform of the box corners).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np


@dataclass(frozen=True)
class Roi:
    """Rotated square in image pixels: centre (cx, cy), side ``size``, ``rotation`` radians."""

    cx: float
    cy: float
    size: float
    rotation: float = 0.0

    @property
    def center(self) -> np.ndarray:
        return np.array([self.cx, self.cy])


def normalize_radians(angle: float) -> float:
    """Wrap to [-π, π)."""
    return angle - 2 * math.pi * math.floor((angle + math.pi) / (2 * math.pi))


def roi_from_alignment_points(center, scale_point, scale: float = 1.25, target_angle: float = math.pi / 2) -> Roi:
    """MediaPipe's AlignmentPointsRects + RectTransformation(scale, square_long).

    ``center`` (2,) is the hip centre, ``scale_point`` (2,) the point encoding
    body size and rotation, both image pixels. Side = 2·|scale_point − center|·scale;
    rotation makes the centre→scale_point vector point up in the crop.
    """
    (x0, y0), (x1, y1) = np.asarray(center, float), np.asarray(scale_point, float)
    box = 2.0 * math.hypot(x1 - x0, y1 - y0)
    rotation = normalize_radians(target_angle - math.atan2(-(y1 - y0), x1 - x0))
    return Roi(cx=float(x0), cy=float(y0), size=box * scale, rotation=rotation)


def letterbox_roi(width: int, height: int) -> Roi:
    """The ROI of a whole frame fitted into a square with padding (keep aspect ratio)."""
    return Roi(cx=width / 2.0, cy=height / 2.0, size=float(max(width, height)), rotation=0.0)


def crop_to_image_matrix(roi: Roi, out_size: int) -> np.ndarray:
    """(2,3) affine matrix taking crop pixel (u, v, 1) to image pixel (x, y)."""
    c, s = math.cos(roi.rotation), math.sin(roi.rotation)
    k = roi.size / out_size
    a = np.array([[c * k, -s * k], [s * k, c * k]])
    offset = roi.center - a @ np.array([out_size / 2.0, out_size / 2.0])
    return np.hstack([a, offset[:, None]])


def crop(image: np.ndarray, roi: Roi, out_size: int, border: str = "replicate") -> np.ndarray:
    """Bilinear crop of ``roi`` from ``image`` (H,W,C) → (out_size, out_size, C), same dtype.

    ``border`` is "replicate" (landmark model) or "zero" (detector letterbox).
    """
    modes = {"replicate": cv2.BORDER_REPLICATE, "zero": cv2.BORDER_CONSTANT}
    if border not in modes:
        raise ValueError(f"expected border 'replicate' or 'zero', got {border!r}")
    return cv2.warpAffine(
        image,
        crop_to_image_matrix(roi, out_size),
        (out_size, out_size),
        flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
        borderMode=modes[border],
        borderValue=0,
    )


def crop_to_image(points: np.ndarray, roi: Roi, out_size: int) -> np.ndarray:
    """Map crop pixel coordinates (N,2) to image pixel coordinates (N,2)."""
    m = crop_to_image_matrix(roi, out_size)
    return points @ m[:, :2].T + m[:, 2]


def rotate_xy(points: np.ndarray, angle: float) -> np.ndarray:
    """Rotate the x, y columns of (N,≥2) points by R(angle); other columns unchanged."""
    c, s = math.cos(angle), math.sin(angle)
    out = np.array(points, dtype=float, copy=True)
    out[:, 0] = c * points[:, 0] - s * points[:, 1]
    out[:, 1] = s * points[:, 0] + c * points[:, 1]
    return out
