"""Model-free parts of the BlazePose pipeline: crops, anchors, decoding, NMS, refinement, filters."""

from __future__ import annotations

import math

import numpy as np
import pytest

from lifting.blazepose.detector import (
    Detection,
    decode,
    iou,
    merge_detections,
    ssd_anchors,
    weighted_nms,
)
from lifting.blazepose.filters import OneEuroFilter
from lifting.blazepose.geometry import (
    Roi,
    crop,
    crop_to_image,
    crop_to_image_matrix,
    normalize_radians,
    roi_from_alignment_points,
)
from lifting.blazepose.landmarks import decode_landmarks, refine_with_heatmap
from lifting.blazepose.tracker import choose_detection


# -- ROIs and crops ---------------------------------------------------------------------
def test_upright_alignment_gives_unrotated_square():
    roi = roi_from_alignment_points((100.0, 200.0), (100.0, 100.0))
    assert (roi.cx, roi.cy) == (100.0, 200.0)
    assert roi.size == pytest.approx(2 * 100 * 1.25)
    assert roi.rotation == pytest.approx(0.0)


@pytest.mark.parametrize("direction", [(1, 0), (0, 1), (-1, 0), (1, -1), (-3, 2)])
def test_crop_up_points_from_centre_to_scale_point(direction):
    """The crop's top-centre must lie along centre → scale point (body up)."""
    centre = np.array([300.0, 200.0])
    d = np.array(direction, float) / np.linalg.norm(direction)
    roi = roi_from_alignment_points(centre, centre + 80 * d)
    top_centre = crop_to_image(np.array([[128.0, 0.0]]), roi, 256)[0]
    np.testing.assert_allclose(top_centre, centre + d * roi.size / 2, atol=1e-9)
    assert -math.pi <= roi.rotation < math.pi


def test_roi_corners_map_to_crop_borders():
    roi = Roi(50.0, 60.0, 40.0, 0.3)
    corners = crop_to_image(np.array([[0.0, 0.0], [256.0, 256.0]]), roi, 256)
    c, s = math.cos(0.3), math.sin(0.3)
    rot = np.array([[c, -s], [s, c]])
    np.testing.assert_allclose(corners[0], roi.center + rot @ [-20, -20])
    np.testing.assert_allclose(corners[1], roi.center + rot @ [20, 20])
    assert crop_to_image_matrix(roi, 256).shape == (2, 3)


def test_crop_samples_the_predicted_pixels():
    """A bright dot drawn in the image shows up in the crop where the matrix says."""
    image = np.zeros((200, 300, 3), np.uint8)
    image[120, 170] = 255
    roi = Roi(150.0, 100.0, 90.0, 0.7)
    patch = crop(image, roi, 64)
    v, u = np.unravel_index(np.argmax(patch[..., 0]), patch.shape[:2])
    back = crop_to_image(np.array([[u, v]], float), roi, 64)[0]
    assert np.linalg.norm(back - [170, 120]) < 90 / 64 * 1.5


def test_crop_border_modes():
    image = np.full((10, 10, 3), 200, np.uint8)
    far = Roi(5.0, 5.0, 40.0, 0.0)
    assert crop(image, far, 16, border="zero")[0, 0, 0] == 0
    assert crop(image, far, 16, border="replicate")[0, 0, 0] == 200
    with pytest.raises(ValueError, match="expected border"):
        crop(image, far, 16, border="wrap")


def test_normalize_radians_range():
    for a in np.linspace(-20, 20, 81):
        b = normalize_radians(a)
        assert -math.pi <= b < math.pi
        assert math.isclose(math.cos(a), math.cos(b), abs_tol=1e-9)


# -- detector decoding ---------------------------------------------------------------
def test_ssd_anchor_layout():
    a = ssd_anchors()
    assert a.shape == (2254, 2)
    np.testing.assert_allclose(a[0], [0.5 / 28, 0.5 / 28])
    np.testing.assert_allclose(a[1], a[0])  # 2 anchors per 28×28 cell
    np.testing.assert_allclose(a[2], [1.5 / 28, 0.5 / 28])  # row-major: x varies first
    np.testing.assert_allclose(a[1568], [0.5 / 14, 0.5 / 14])
    np.testing.assert_allclose(a[1960:1966], np.tile([0.5 / 7, 0.5 / 7], (6, 1)))  # 6 per 7×7 cell
    np.testing.assert_allclose(a[-1], [6.5 / 7, 6.5 / 7])


def test_decode_offsets_and_sigmoid():
    anchors = np.array([[0.5, 0.25]])
    raw = np.array([[22.4, -11.2, 44.8, 22.4, 0, 0, 11.2, 0, 0, 11.2, 0, 0]], np.float32)
    scores, boxes, kps = decode(raw, np.array([0.0, 200.0])[:1], anchors)
    assert scores[0] == pytest.approx(0.5)
    np.testing.assert_allclose(boxes[0], [0.5, 0.15, 0.7, 0.25], atol=1e-6)
    np.testing.assert_allclose(kps[0], [[0.5, 0.25], [0.55, 0.25], [0.5, 0.3], [0.5, 0.25]], atol=1e-6)
    clipped, _, _ = decode(raw, np.array([1e6]), anchors)
    assert np.isfinite(clipped).all()


def test_weighted_nms_merges_overlaps_and_keeps_separate_boxes():
    boxes = np.array([[0, 0, 1, 1], [0.1, 0, 1.1, 1], [3, 3, 4, 4], [0, 0, 1, 1]], float)
    kps = np.zeros((4, 4, 2))
    kps[:, 0, 0] = [0.0, 1.0, 5.0, 9.0]
    scores = np.array([0.9, 0.6, 0.8, 0.3])
    out = weighted_nms(scores, boxes, kps, min_score=0.5)
    assert [round(s, 2) for s, _, _ in out] == [0.9, 0.8]
    np.testing.assert_allclose(out[0][1], (0.9 * boxes[0] + 0.6 * boxes[1]) / 1.5)
    assert out[0][2][0, 0] == pytest.approx(0.6 / 1.5)  # keypoints averaged too; the 0.3 box is dropped
    np.testing.assert_allclose(out[1][1], boxes[2])
    assert iou(boxes[0], boxes[1:2])[0] == pytest.approx(0.9 / 1.1)


def _det(score, hips, size=100.0):
    kps = np.array([hips, [hips[0], hips[1] - size / 2.5], hips, hips], float)
    return Detection(score, np.array([hips[0] - 10, hips[1] - 10, hips[0] + 10, hips[1] + 10]), kps)


def test_merge_detections_removes_tile_duplicates():
    merged = merge_detections([_det(0.6, (100, 100)), _det(0.9, (105, 98)), _det(0.7, (400, 100))])
    assert [d.score for d in merged] == [0.9, 0.7]


# -- main-person choice ----------------------------------------------------------------
def test_choose_largest_at_start_then_nearest_within_growing_gate():
    small, large = _det(0.95, (100, 300), size=80), _det(0.6, (500, 300), size=200)
    assert choose_detection([small, large], [], None) is large
    recent = [large.roi()] * 5  # tracked at x=500, crop size 200
    bystander = _det(0.99, (100, 300), size=200)  # 400 px = 2 crop sizes away
    assert choose_detection([bystander], recent, 0.1) is None
    assert choose_detection([bystander], recent, 1.5) is None  # radius 0.75 + 0.75·1.5 < 2
    assert choose_detection([bystander], recent, 1.8) is bystander  # gate has grown past it
    assert choose_detection([bystander], recent, 10.0) is bystander  # forgotten: start over
    near = _det(0.55, (560, 310), size=190)
    assert choose_detection([bystander, near], recent, 0.1) is near


# -- landmarks ---------------------------------------------------------------------------
def test_heatmap_refinement_moves_to_weighted_peak():
    heat = np.full((64, 64, 3), -10.0)
    heat[30, 40, 0] = 10.0  # sharp confident peak
    heat[5, 5, 1] = -1.0  # weak (max confidence < 0.5): keep as is
    xy = np.array([[41.5 / 64, 31.2 / 64], [5 / 64, 5 / 64], [1.5, 0.5]])  # third is outside
    out = refine_with_heatmap(xy, heat)
    np.testing.assert_allclose(out[0], [40 / 64, 30 / 64], atol=2e-3)
    np.testing.assert_allclose(out[1:], xy[1:])
    with pytest.raises(ValueError, match="expected xy of shape"):
        refine_with_heatmap(xy[:2], heat)


def test_decode_landmarks_projects_and_rotates_world():
    raw = np.zeros((39, 5), np.float32)
    raw[:, 0], raw[:, 1] = 128.0, 64.0  # centre column, a quarter from the top
    raw[:, 2], raw[:, 3], raw[:, 4] = 25.6, 0.0, 100.0
    world = np.tile(np.array([0.0, -1.0, 0.5], np.float32), 39)
    roi = Roi(300.0, 200.0, 200.0, math.pi / 2)
    out = decode_landmarks(raw.reshape(-1), 0.9, np.full((64, 64, 39), -20.0), world, roi)
    # Crop "up" is image +x for this rotation: a quarter from the top = 50 px right of centre.
    np.testing.assert_allclose(out.image[0], [350.0, 200.0, 20.0], atol=1e-6)
    np.testing.assert_allclose(out.world[0], [1.0, 0.0, 0.5], atol=1e-6)
    np.testing.assert_allclose(out.visibility, 0.5)
    assert out.presence.min() > 0.99 and out.score == 0.9


# -- one-euro filter ---------------------------------------------------------------------
def test_one_euro_filter_smooths_jitter_but_follows_motion():
    rng = np.random.default_rng(0)
    f = OneEuroFilter()
    times = np.arange(60) / 30.0
    still = [f(np.array([100.0]) + rng.normal(0, 2, 1), t, 1 / 100)[0] for t in times]
    assert np.std(still[20:]) < 0.2  # raw jitter std 2
    f.reset()
    moving = [f(np.array([10.0 * i]), t, 1 / 100)[0] for i, t in enumerate(times)]
    assert moving[-1] > 0.5 * 10 * 59  # follows a 300 px/s motion with bounded lag
    assert moving[-1] < 10 * 59
    with pytest.raises(ValueError, match="expected values of shape"):
        f(np.zeros(2), 5.0)
