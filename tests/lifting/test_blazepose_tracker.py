"""PoseTracker / lifting.tracking.track on synthetic humanoid renders (needs the models)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from lifting.blazepose.results import POSE_LANDMARKS, TrackResult
from lifting.tracking import track
from testkit.synthetic_blazepose import (
    draw_humanoid,
    humanoid_frame,
    humanoid_joints,
    write_walking_clip,
)

# BlazePose index -> synthetic joint (the figure faces the camera: its left is image right)
JOINTS = {
    11: "l_shoulder", 12: "r_shoulder", 13: "l_elbow", 14: "r_elbow", 15: "l_wrist", 16: "r_wrist",
    23: "l_hip", 24: "r_hip", 25: "l_knee", 26: "r_knee", 27: "l_ankle", 28: "r_ankle",
}  # fmt: skip
W, H = 640, 480


def test_landmark_names():
    assert len(POSE_LANDMARKS) == 33 and POSE_LANDMARKS[0] == "nose" and POSE_LANDMARKS[32] == "right_foot_index"


@pytest.mark.parametrize("phase", [0.0, 1.2])
def test_single_frame_landmarks_on_the_figure(tracker, phase):
    tracker.reset()
    pose = tracker.process(humanoid_frame(W, H, phase), 0.0)
    assert pose.found and pose.detected and pose.score > 0.9
    assert pose.world.shape == pose.image.shape == (33, 3)
    assert pose.visibility.shape == pose.presence.shape == (33,)
    figure_height = 0.8 * H
    joints = humanoid_joints(W / 2, 0.08 * H, figure_height, phase)
    errors = {name: np.linalg.norm(pose.image[i, :2] - joints[name]) / figure_height for i, name in JOINTS.items()}
    assert max(errors.values()) < 0.1, errors
    # World frame: metres, hip-centred, Y up, Z toward the camera (the figure faces it).
    w = pose.world
    np.testing.assert_allclose((w[23] + w[24]) / 2, 0.0, atol=0.05)
    assert w[0, 1] > 0.4 and w[27, 1] < -0.5 and w[28, 1] < -0.5  # nose up, ankles down
    assert w[0, 2] > 0.1  # nose nearer the camera than the hips
    assert w[11, 0] > w[12, 0]  # left shoulder on the image's right
    assert 0.2 < np.linalg.norm(w[11] - w[12]) < 0.6  # plausible shoulder width in metres


def test_rotated_frame_world_follows_the_image(tracker):
    """A figure lying with its head at the image's right: world 'up' stays the image's up."""
    tracker.reset()
    pose = tracker.process(cv2.rotate(humanoid_frame(W, H, 0.3), cv2.ROTATE_90_CLOCKWISE), 0.0)
    assert pose.found
    assert abs(np.degrees(pose.roi.rotation) - 90) < 20
    assert pose.world[0, 0] > 0.4 and abs(pose.world[0, 1]) < 0.2


def test_no_person_gives_nan_and_not_found(tracker):
    tracker.reset()
    pose = tracker.process(np.full((H, W, 3), 200, np.uint8), 0.0)
    assert not pose.found and pose.score < 0.5
    assert np.isnan(pose.world).all() and np.isnan(pose.image).all() and np.isnan(pose.visibility).all()


def test_follows_one_person_and_ignores_a_bystander(tracker):
    """Left figure tracked; a second figure appears on the right; the left one vanishes
    for 0.2 s (the right one must not be picked up), then comes back."""
    both = humanoid_frame(2 * W, H, 0.0, cx=0.5 * W)
    draw_humanoid(both, 1.5 * W, 0.1 * H, 0.8 * H, 0.5)
    left_only = humanoid_frame(2 * W, H, 0.0, cx=0.5 * W)
    right_only = humanoid_frame(2 * W, H, 0.0, cx=-W)  # main figure drawn off-frame
    draw_humanoid(right_only, 1.5 * W, 0.1 * H, 0.8 * H, 0.5)
    frames = [left_only] * 2 + [both] * 3 + [right_only] * 6 + [both] * 2
    tracker.reset()
    poses = [tracker.process(f, i / 30) for i, f in enumerate(frames)]
    found = [p.found for p in poses]
    assert found == [True] * 5 + [False] * 6 + [True] * 2
    assert all(p.image[0, 0] < W for p in poses if p.found)  # always the left figure
    assert any(p.detected for p in poses[5:11])  # the detector did look while lost


def test_rejects_bad_frames(tracker):
    with pytest.raises(ValueError, match="expected an \\(H,W,3\\) uint8 BGR frame"):
        tracker.process(np.zeros((10, 10), np.uint8))


def test_track_on_synthetic_clip(tmp_path, tracker):
    clip = write_walking_clip(tmp_path / "walk.mp4", width=W, height=H, n_frames=30, fps=30.0)
    result = track(clip, tracker=tracker)
    assert isinstance(result, TrackResult)
    assert (result.fps, result.width, result.height) == (pytest.approx(30.0), W, H)
    assert result.world.shape == result.image.shape == (30, 33, 3)
    assert result.visibility.shape == result.presence.shape == (30, 33)
    assert result.found.dtype == bool and result.found.all()
    assert result.detector_runs == 1  # tracked from the first detection on
    np.testing.assert_allclose(result.times, np.arange(30) / 30.0)
    # The figure drifts sideways: the nose follows the drawn head.
    heads = [
        humanoid_joints(W / 2 + 0.15 * W * np.sin(2 * np.pi * i / 30), 0.08 * H, 0.8 * H, 2 * np.pi * i / 30)["head"]
        for i in range(30)
    ]
    assert np.max(np.linalg.norm(result.image[:, 0, :2] - np.array(heads), axis=1)) < 0.06 * H
    # Smoothed crops keep the world skeleton steady: shoulder width varies little.
    width = np.linalg.norm(result.world[:, 11] - result.world[:, 12], axis=1)
    assert width.std() < 0.03
