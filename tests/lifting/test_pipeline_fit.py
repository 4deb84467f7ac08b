"""The pose pipeline's numerical parts, without the BlazePose models: skeleton fit, low-pass,
gap handling, camera translation, contacts and floor."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from lifting.blazepose.results import POSE_LANDMARKS
from lifting.camera import solve_translation
from lifting.filtering import interpolate_gaps, longest_segment, lowpass, runs
from lifting.fit import (
    ANCHORS,
    DIRECT,
    FOOT_CLEARANCE,
    blend_paths,
    contact_trajectory,
    floor_lift,
    foot_clearance,
    head_rotation,
    landmarks_to_joints,
    moving_ground,
    up_rotation,
)
from motioncore import quat
from motioncore.ik_fit import default_reference, fit_positions
from motioncore.motion import Motion
from motioncore.skeleton import CANONICAL

SK = CANONICAL.skeleton


def random_motion(n: int = 40, seed: int = 0, spread: float = 0.6) -> Motion:
    """Smoothly varying random local rotations around the reference pose, a wandering root."""
    g = torch.Generator().manual_seed(seed)
    t = torch.linspace(0, 1, n)[:, None, None]
    a, b = (torch.randn(2, 1, SK.num_joints, 3, generator=g) * spread)
    axis_angle = a * torch.sin(3 * t) + b * torch.cos(2 * t)  # (n, J, 3)
    angle = axis_angle.norm(dim=-1)
    delta = quat.from_axis_angle(torch.nn.functional.normalize(axis_angle, dim=-1), angle)
    lrot = quat.mul(default_reference().expand(n, -1, -1), delta)
    lpos = SK.offsets.expand(n, -1, -1).clone()
    lpos[:, 0] = torch.stack([torch.sin(2 * t[:, 0, 0]), 0.9 + 0.05 * t[:, 0, 0], 2 * t[:, 0, 0]], -1)
    return Motion(SK, lrot, lpos, 30.0)


# ---------------------------------------------------------------- skeleton fit


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("relative", [True, False])
def test_fit_reproduces_fk_positions(seed, relative):
    truth = random_motion(seed=seed)
    target = truth.global_positions()
    fitted = fit_positions(target, truth.fps, relative=relative)
    assert fitted.skeleton is SK and fitted.num_frames == truth.num_frames and fitted.fps == truth.fps
    err = (fitted.global_positions() - target).norm(dim=-1)
    assert float(err.max()) < 1e-3  # metres: bone lengths match, so positions are reproduced
    torch.testing.assert_close(fitted.lpos[:, 1:], SK.offsets[1:].expand(truth.num_frames, -1, -1))  # constant bones


def test_fit_keeps_the_reference_convention():
    """The reference pose itself comes back with its (twisted) rotations, not shortest-arc ones."""
    ref = default_reference()
    lpos = SK.offsets[None].clone()
    truth = Motion(SK, ref[None], lpos, 20.0)
    fitted = fit_positions(truth.global_positions(), 20.0)
    non_leaf = [j for j in range(SK.num_joints) if SK.children(j)]
    angle = quat.angle(quat.mul(quat.inv(ref[non_leaf]), fitted.lrot[0, non_leaf]))
    assert float(torch.rad2deg(angle).max()) < 1.0
    # A fit without the reference (plain shortest arc from the T-pose) would not be:
    plain = fit_positions(truth.global_positions(), 20.0, reference=quat.identity(SK.num_joints), hinges={})
    spine = SK.index("Spine")
    assert float(torch.rad2deg(quat.angle(quat.mul(quat.inv(ref[spine]), plain.lrot[0, spine])))) > 45


def test_fit_hinge_bends_knee_about_its_axis():
    """With the hinge twist the knee's local rotation is about the data's knee axis (±X)."""
    truth = random_motion(seed=3, spread=0.8)
    fitted = fit_positions(truth.global_positions(), truth.fps)
    knee = SK.index("LowerLeg_L")
    q = fitted.lrot[:, knee]
    axis = torch.nn.functional.normalize(q[:, 1:], dim=-1)
    bent = quat.angle(q) > math.radians(30)
    assert bent.any()
    assert float(axis[bent, 0].abs().min()) > 0.9


def test_fit_rejects_bad_targets():
    with pytest.raises(ValueError, match="expected targets"):
        fit_positions(torch.zeros(4, 20, 3), 30.0)
    bad = torch.zeros(4, SK.num_joints, 3)
    bad[1, 3] = float("nan")
    with pytest.raises(ValueError, match="NaN"):
        fit_positions(bad, 30.0)


# ---------------------------------------------------------------- landmarks -> joints


def landmarks_from(motion: Motion) -> np.ndarray:
    """Fake BlazePose world landmarks (33, 3) per frame placed on a canonical motion's joints."""
    grot, gpos = (x.double().numpy() for x in _fk(motion))
    out = np.zeros((motion.num_frames, 33, 3))
    for joint, lm in DIRECT.items():
        out[:, POSE_LANDMARKS.index(lm)] = gpos[:, SK.index(joint)]
    head = quat.to_matrix(torch.from_numpy(grot[:, SK.index("Head")])).numpy()
    centre = gpos[:, SK.index("Head")] + 0.07 * head[..., 1]
    out[:, POSE_LANDMARKS.index("left_ear")] = centre + 0.08 * head[..., 0]
    out[:, POSE_LANDMARKS.index("right_ear")] = centre - 0.08 * head[..., 0]
    out[:, POSE_LANDMARKS.index("nose")] = centre + 0.1 * head[..., 2] - 0.027 * head[..., 1]
    return out


def _fk(motion: Motion):
    from motioncore.kinematics import fk

    return fk(motion.lrot.double(), motion.lpos.double(), SK.parents)


def test_landmark_joints_fit_close_to_truth():
    truth = random_motion(seed=4, spread=0.4)
    world = landmarks_from(truth)
    joints = landmarks_to_joints(world)
    assert joints.shape == (truth.num_frames, SK.num_joints, 3)
    fitted = fit_positions(torch.from_numpy(joints), truth.fps, anchors=ANCHORS,
                           leaf_rotations={SK.index("Head"): head_rotation(world)})
    err = (fitted.global_positions().double() - truth.global_positions().double()).norm(dim=-1)
    assert float(err.mean()) < 0.03  # the torso joints without landmarks are placed as in the mean pose


def test_head_rotation_of_a_level_face_is_identity():
    world = np.zeros((1, 33, 3))
    world[0, POSE_LANDMARKS.index("left_ear")] = (0.08, 1.6, 0.0)
    world[0, POSE_LANDMARKS.index("right_ear")] = (-0.08, 1.6, 0.0)
    a = math.radians(15.0)
    world[0, POSE_LANDMARKS.index("nose")] = (0.0, 1.6 - 0.1 * math.sin(a), 0.1 * math.cos(a))
    q = head_rotation(world)
    assert q.dtype == torch.float64 and math.degrees(float(quat.angle(q[0]))) < 0.5


# ---------------------------------------------------------------- filtering


def test_lowpass_is_zero_phase_and_cuts_fast_motion():
    fps = 30.0
    t = np.arange(300) / fps
    slow, fast = np.sin(2 * np.pi * 1.0 * t), np.sin(2 * np.pi * 8.0 * t)
    out_slow = lowpass(slow, fps, 3.0)
    out_fast = lowpass(fast, fps, 3.0)
    mid = slice(30, -30)
    assert np.abs(out_slow - slow)[mid].max() < 0.02  # 1 Hz kept, no lag (zero phase)
    assert np.argmax(out_slow[30:60]) == np.argmax(slow[30:60])
    assert np.abs(out_fast[mid]).max() < 0.01  # 8 Hz removed
    both = lowpass(np.stack([slow, fast], 1)[:, None], fps, 3.0)  # any trailing shape, along axis 0
    assert both.shape == (300, 1, 2)
    np.testing.assert_allclose(both[:, 0, 0], out_slow)


def test_lowpass_edge_cases():
    x = np.random.default_rng(0).normal(size=(5, 3))
    assert lowpass(x, 30.0, 3.0).shape == (5, 3)  # shorter than the default padding
    np.testing.assert_array_equal(lowpass(x, 30.0, None), x)
    np.testing.assert_array_equal(lowpass(x, 30.0, 20.0), x)  # above Nyquist: nothing to cut
    with pytest.raises(ValueError, match="finite"):
        lowpass(np.array([0.0, np.nan, 1.0, 2.0]), 30.0, 3.0)


def test_gap_interpolation_and_segments():
    x = np.arange(10, dtype=float)[:, None] * 2.0
    valid = np.ones(10, bool)
    valid[[0, 4, 5, 9]] = False
    filled = interpolate_gaps(np.where(valid[:, None], x, np.nan), valid)
    np.testing.assert_allclose(filled[1:9, 0], x[1:9, 0])
    assert filled[0, 0] == 2.0 and filled[9, 0] == 16.0  # ends hold the nearest value
    assert runs(np.array([0, 1, 1, 0, 1], bool)) == [(1, 3), (4, 5)]
    found = np.array([1, 1, 0, 1, 1, 1, 0, 0, 0, 0, 1, 1], bool)
    assert longest_segment(found, max_gap=1) == (0, 6)
    assert longest_segment(found, max_gap=4) == (0, 12)
    assert longest_segment(np.zeros(4, bool), 2) == (0, 0)


# ---------------------------------------------------------------- camera translation


def test_translation_from_a_pinhole_projection():
    rng = np.random.default_rng(1)
    n, k, focal, centre = 20, 12, 900.0, (640.0, 360.0)
    points = rng.normal(scale=0.4, size=(n, k, 3))  # hip-centred, Y-up, z toward the camera
    t_true = np.stack([np.linspace(-1, 1, n), np.linspace(-0.3, -0.1, n), np.linspace(-6, -3, n)], 1)
    cam = (points + t_true[:, None]) * np.array([1.0, -1.0, -1.0])  # -> x right, y down, z forward
    pixels = focal * cam[..., :2] / cam[..., 2:] + np.array(centre)
    t = solve_translation(points, pixels, np.ones((n, k)), focal, centre)
    np.testing.assert_allclose(t, t_true, atol=1e-6)
    noisy = solve_translation(points, pixels + rng.normal(scale=1.0, size=pixels.shape), np.ones((n, k)), focal, centre)
    assert np.abs(noisy - t_true).max() < 0.2  # 1 px noise: depth within centimetres to decimetres


# ---------------------------------------------------------------- ground, contacts, path


def walking_feet(n: int = 90, fps: float = 30.0, speed: float = 1.2):
    """Root-relative positions ``(n, J, 3)`` (only the feet matter) of an idealised walk along +Z,
    and the true root path: each foot is planted for half of a 1 s cycle and swings the other half."""
    t = np.arange(n) / fps
    root = np.stack([np.zeros(n), np.full(n, 0.93), speed * t], 1)
    rel = np.zeros((n, SK.num_joints, 3))
    stride = speed * 1.0
    for side, phase in ((0, 0.0), (1, 0.5)):
        cycle = (t + phase) % 1.0
        step = np.floor(t + phase)
        swing = np.clip((cycle - 0.5) / 0.5, 0.0, 1.0)  # 0 while planted
        z = stride * (step + 0.25 - phase + swing)  # world z of the ankle
        lift = 0.08 * np.sin(np.pi * swing)
        for j in (2 * side, 2 * side + 1):
            toe = j % 2
            rel[:, CANONICAL.feet[j]] = np.stack(
                [np.full(n, 0.09 - 0.18 * side), FOOT_CLEARANCE[j] + lift - 0.93, z + 0.1 * toe - root[:, 2]], 1)
    return rel, root


def test_contact_path_walks_on_a_treadmill():
    rel, root = walking_feet()
    fps = 30.0
    treadmill = root * np.array([1.0, 1.0, 0.0])  # the camera sees the person stay in place
    path, contacts = contact_trajectory(rel, treadmill, fps)
    assert contacts.shape == (len(root), 4) and (contacts.sum(1) > 0.5).mean() > 0.9
    speed = (path[-1, 2] - path[0, 2]) / ((len(root) - 1) / fps)
    assert speed == pytest.approx(1.2, rel=0.1)
    assert moving_ground(path, treadmill, fps)
    assert not moving_ground(path, root, fps)
    # With a right camera path the blend stays on it (and the feet stay planted).
    blended = blend_paths(path, root, fps)
    assert np.abs(blended[:, [0, 2]] - root[:, [0, 2]]).max() < 0.1


def test_floor_lift_keeps_feet_above_the_floor():
    rel, root = walking_feet()
    y = root[:, 1] - 0.05 + 0.04 * np.sin(np.arange(len(root)))  # some frames sink
    lift = floor_lift(rel, y, 30.0)
    assert (lift >= 0).all()
    assert foot_clearance(rel, y + lift).min() >= -1e-9
    assert not floor_lift(rel, y + 1.0, 30.0).any()


def test_up_rotation_levels_a_tilted_body():
    ref = Motion(SK, default_reference()[None].expand(10, -1, -1), SK.offsets.expand(10, -1, -1).clone(), 30.0)
    pos = ref.global_positions().double()
    x_axis = torch.tensor([1.0, 0.0, 0.0], dtype=torch.float64)
    q0 = up_rotation(pos.numpy())
    assert math.degrees(float(quat.angle(q0))) < 10.0  # the mean pose stands nearly upright
    tilt = quat.from_axis_angle(x_axis, torch.tensor(math.radians(12.0), dtype=torch.float64))
    q = up_rotation(quat.mul_vec(tilt, pos).numpy())
    # Levelling the tilted body gives what levelling the upright one gives (up to a turn about Y).
    diff = quat.mul(quat.mul(q, tilt), quat.inv(q0))
    y = torch.tensor([0.0, 1.0, 0.0], dtype=torch.float64)
    torch.testing.assert_close(quat.mul_vec(diff, y), y)
    upside_down = quat.mul_vec(quat.from_axis_angle(x_axis, torch.tensor(math.pi, dtype=torch.float64)), pos).numpy()
    torch.testing.assert_close(up_rotation(upside_down), torch.tensor([1.0, 0.0, 0.0, 0.0], dtype=torch.float64))  # not upright: left alone
