"""BlazePose landmarks -> canonical joint targets, camera translation, ground and facing.

Frames: BlazePose *world* landmarks come hip-centred in a Y-up frame aligned with the camera
(x right, y up, z toward the camera), so a person facing the camera faces +Z with their left
at +X, as the canonical skeleton does. The pinhole camera is in :mod:`lifting.camera`.
"""

from __future__ import annotations

import math

import numpy as np
import torch

from lifting.blazepose.results import POSE_LANDMARKS
from lifting.filtering import lowpass, maximum_1d, mean_1d, percentile_1d
from motioncore import quat
from motioncore.kinematics import rest_positions
from motioncore.skeleton import CANONICAL

_IDENTITY = torch.tensor([1.0, 0.0, 0.0, 0.0], dtype=torch.float64)
_Y_UP = torch.tensor([0.0, 1.0, 0.0], dtype=torch.float64)
HEAD_PITCH_DEG = 15.0  # the nose sits below the ear line: forward = nose - ears, tilted up by this

_L = {n: i for i, n in enumerate(POSE_LANDMARKS)}
_SK = CANONICAL.skeleton
_REST = rest_positions(_SK.offsets.double(), _SK.parents).numpy()

# Canonical joints placed directly on a landmark (also the correspondences of the camera solve).
DIRECT = {
    "UpperArm_L": "left_shoulder", "UpperArm_R": "right_shoulder",
    "LowerArm_L": "left_elbow", "LowerArm_R": "right_elbow",
    "Hand_L": "left_wrist", "Hand_R": "right_wrist",
    "UpperLeg_L": "left_hip", "UpperLeg_R": "right_hip",
    "LowerLeg_L": "left_knee", "LowerLeg_R": "right_knee",
    "Foot_L": "left_ankle", "Foot_R": "right_ankle",
    "Toes_L": "left_foot_index", "Toes_R": "right_foot_index",
}  # fmt: skip
CAMERA_JOINTS = [j for j in DIRECT if not j.startswith("Toes")]

# Chest's rotation is fitted to the neck and the shoulder joints (measured), not the collars.
ANCHORS = {_SK.index("Chest"): [_SK.index(n) for n in ("Neck", "UpperArm_L", "UpperArm_R")]}


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-9)


def _frame(across: np.ndarray, up: np.ndarray) -> np.ndarray:
    """Right-handed frames ``(*, 3, 3)`` (columns x, y, z) from a left-pointing ``across`` and an
    approximate ``up``: x = across, y = up made perpendicular, z = x cross y (forward)."""
    x = _unit(across)
    y = _unit(up - (up * x).sum(-1, keepdims=True) * x)
    return np.stack([x, y, np.cross(x, y)], axis=-1)


def _reference_pose() -> np.ndarray:
    from motioncore.ik_fit import default_reference
    from motioncore.kinematics import fk

    return fk(default_reference(_SK).double()[None], _SK.offsets.double()[None], _SK.parents)[1][0].numpy()


_REF = _reference_pose()  # joint positions of the reference (mean) pose, Hips at the origin


def landmarks_to_joints(world: np.ndarray) -> np.ndarray:
    """World landmarks ``(T, 33, 3)`` -> canonical joint targets ``(T, 21, 3)`` in the same frame.

    Limb joints sit on their landmarks (:data:`DIRECT`), Head at mid-ears. The joints with no
    landmark are placed as in the reference pose (the mean pose of the training data): Hips and
    Spine relative to the hips' frame (across the hips, up the torso), Chest, Neck and the
    collars relative to the shoulders' frame.
    """
    w = np.asarray(world, np.float64)
    out = np.zeros(w.shape[:-2] + (_SK.num_joints, 3))
    for j, lm in DIRECT.items():
        out[..., _SK.index(j), :] = w[..., _L[lm], :]
    ix = _SK.index
    hip_l, hip_r = w[..., _L["left_hip"], :], w[..., _L["right_hip"], :]
    sh_l, sh_r = w[..., _L["left_shoulder"], :], w[..., _L["right_shoulder"], :]
    mid_hip, mid_sh = 0.5 * (hip_l + hip_r), 0.5 * (sh_l + sh_r)
    ref_hip = 0.5 * (_REF[ix("UpperLeg_L")] + _REF[ix("UpperLeg_R")])
    ref_sh = 0.5 * (_REF[ix("UpperArm_L")] + _REF[ix("UpperArm_R")])
    ref_pelvis = _frame(_REF[ix("UpperLeg_L")] - _REF[ix("UpperLeg_R")], ref_sh - ref_hip)
    ref_chest = _frame(_REF[ix("UpperArm_L")] - _REF[ix("UpperArm_R")], ref_sh - ref_hip)
    pelvis = _frame(hip_l - hip_r, mid_sh - mid_hip)
    chest = _frame(sh_l - sh_r, mid_sh - mid_hip)
    for name in ("Hips", "Spine"):
        local = ref_pelvis.T @ (_REF[ix(name)] - ref_hip)
        out[..., ix(name), :] = mid_hip + pelvis @ local
    for name in ("Chest", "Neck", "Shoulder_L", "Shoulder_R"):
        local = ref_chest.T @ (_REF[ix(name)] - ref_sh)
        out[..., ix(name), :] = mid_sh + chest @ local
    out[..., ix("Head"), :] = 0.5 * (w[..., _L["left_ear"], :] + w[..., _L["right_ear"], :])
    return out


def head_rotation(world: np.ndarray, pitch_deg: float = HEAD_PITCH_DEG) -> torch.Tensor:
    """Global head rotation ``(T, 4)`` wxyz float64 from ears and nose: +X toward the left ear, +Z the face's
    forward (nose minus mid-ears, tilted up by ``pitch_deg``), +Y up (identity = looking along +Z)."""
    w = np.asarray(world, np.float64)
    left = _unit(w[..., _L["left_ear"], :] - w[..., _L["right_ear"], :])
    fwd = w[..., _L["nose"], :] - 0.5 * (w[..., _L["left_ear"], :] + w[..., _L["right_ear"], :])
    fwd = _unit(fwd - (fwd * left).sum(-1, keepdims=True) * left)
    up = np.cross(fwd, left)
    a = math.radians(pitch_deg)
    fwd, up = math.cos(a) * fwd + math.sin(a) * up, math.cos(a) * up - math.sin(a) * fwd
    m = np.stack([left, up, fwd], axis=-1)
    return quat.from_matrix(torch.from_numpy(m))


def up_rotation(joints: np.ndarray, max_deg: float = 35.0) -> torch.Tensor:
    """Rotation ``(4,)`` float64 taking the clip's median body axis (mid-feet to neck) onto +Y.

    Corrects the camera's pitch and roll, assuming the person is upright on average; when the
    axis is more than ``max_deg`` from the image's up (lying, upside down) nothing is corrected.
    """
    ix = _SK.index
    feet = 0.5 * (joints[:, ix("Foot_L")] + joints[:, ix("Foot_R")])
    axis = _unit(joints[:, ix("Neck")] - feet)
    med = _unit(np.median(axis, axis=0))
    if math.degrees(math.acos(np.clip(med[1], -1.0, 1.0))) > max_deg:
        return _IDENTITY.clone()
    return quat.between(torch.from_numpy(med), _Y_UP)


# Height of each contact joint (Foot_L, Toes_L, Foot_R, Toes_R) above the floor when the foot is flat.
_FEET = list(CANONICAL.feet)
FOOT_CLEARANCE = _REST[_FEET, 1] - _REST[_FEET, 1].min()


def _smoothstep(x: np.ndarray, lo: float, hi: float) -> np.ndarray:
    t = np.clip((x - lo) / (hi - lo), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def foot_clearance(rel: np.ndarray, root_y: np.ndarray) -> np.ndarray:
    """Height of each foot contact joint above the level it has standing flat: ``(T, 4)``, from
    root-relative positions ``rel (T, J, 3)`` and the root height ``root_y (T,)``."""
    return root_y[:, None] + rel[:, _FEET, 1] - FOOT_CLEARANCE


def floor_level(clearance: np.ndarray, fps: float, window_s: float = 2.0) -> np.ndarray:
    """The floor height ``(T,)`` under the camera path: the 10th percentile of the lowest foot
    over a sliding window, so a floor that seems to slope (a slightly wrong camera tilt, depth
    errors of a far person) still meets the feet."""
    low = clearance.min(axis=1)
    size = max(3, 2 * round(0.5 * window_s * fps) + 1)
    if len(low) <= size:
        return np.full(len(low), np.quantile(low, 0.1))
    return percentile_1d(low, 10, size)


def contact_weights(clearance: np.ndarray, floor: np.ndarray | float) -> np.ndarray:
    """Soft contact flags ``(T, 4)`` in [0, 1]: a foot joint touches when it is the lowest of the
    frame (within 3-15 mm) and the lowest is near the floor (within 10-25 cm: jumps let go; the
    camera path's height is too noisy to find the short flights of running)."""
    low = clearance.min(axis=1, keepdims=True)
    relative = 1.0 - _smoothstep(clearance - low, 0.003, 0.015)
    absolute = 1.0 - _smoothstep(low - np.reshape(floor, (-1, 1)), 0.10, 0.25)
    return relative * absolute


def contact_trajectory(rel: np.ndarray, root: np.ndarray, fps: float) -> tuple[np.ndarray, np.ndarray]:
    """Root path ``(T, 3)`` with the floor at y = 0 from foot contacts, and the contact weights
    ``(T, 4)``. ``rel (T, J, 3)``: joints relative to the root; ``root (T, 3)``: the camera path
    (its height finds the floor and flight phases; its start is the path's start).

    While a foot is down it stays where it is: the root moves horizontally by minus the foot's
    motion relative to the root, and stands the leg's height above the floor. With no foot down
    (flight) the horizontal velocity is interpolated between the contacts around it, and the
    height follows the camera path, shifted to meet the contact heights on both sides. A clip
    with no contact at all keeps the camera path.
    """
    clear = foot_clearance(rel, root[:, 1])
    floor = floor_level(clear, fps)
    c = contact_weights(clear, floor)
    total = c.sum(axis=1)
    down = total > 0.5
    y_cam = root[:, 1] - floor
    if not down.any() or len(root) < 3:
        out = root.copy()
        out[:, 1] = y_cam
        return out, c
    t = np.arange(len(root))
    v_rel = np.gradient(rel[:, _FEET][..., [0, 2]], axis=0) * fps
    v = -(c[..., None] * v_rel).sum(axis=1) / np.maximum(total, 1e-9)[:, None]
    v = np.stack([np.interp(t, t[down], v[down, k]) for k in range(2)], axis=-1)
    out = np.empty_like(root)
    out[0, [0, 2]] = root[0, [0, 2]]
    out[1:, [0, 2]] = root[0, [0, 2]] + np.cumsum(0.5 * (v[1:] + v[:-1]), axis=0) / fps
    y_contact = -(c * (rel[:, _FEET, 1] - FOOT_CLEARANCE)).sum(axis=1) / np.maximum(total, 1e-9)
    offset = np.interp(t, t[down], (y_contact - y_cam)[down])
    w = np.clip(total, 0.0, 1.0)
    out[:, 1] = w * np.where(down, y_contact, 0.0) + (1.0 - w) * (y_cam + offset)
    return out, c


def blend_paths(contact: np.ndarray, camera: np.ndarray, fps: float, crossover_hz: float = 0.5) -> np.ndarray:
    """Horizontal path: the camera path below ``crossover_hz`` (where it is right on average),
    the contact path above (where it keeps the feet still). Heights come from ``contact``."""


    out = contact.copy()
    xz = [0, 2]
    out[:, xz] = lowpass(camera[:, xz], fps, crossover_hz, order=2) + contact[:, xz] - lowpass(contact[:, xz], fps, crossover_hz, order=2)
    return out


def moving_ground(contact: np.ndarray, camera: np.ndarray, fps: float) -> bool:
    """True when the legs walk but the camera path barely moves (a treadmill, or a camera that
    follows the person): mean horizontal speeds (below 0.5 Hz) under 35 % of the contact path's,
    which is over 0.3 m/s."""


    if len(contact) < 3:
        return False
    speed = [float(np.linalg.norm(lowpass(np.gradient(p[:, [0, 2]], axis=0) * fps, fps, 0.5, order=2), axis=-1).mean())
             for p in (contact, camera)]
    return speed[0] > 0.3 and speed[1] < 0.35 * speed[0]


def floor_lift(rel: np.ndarray, root_y: np.ndarray, fps: float, window_s: float = 0.15) -> np.ndarray:
    """A smooth non-negative lift ``(T,)`` of the root that keeps every foot at or above y = 0."""
    need = np.maximum(0.0, -foot_clearance(rel, root_y).min(axis=1))
    if not need.any():
        return need
    k = 2 * max(1, round(window_s * fps)) + 1
    lift = mean_1d(maximum_1d(need, k), k)
    return np.maximum(lift, need)  # the box average of the dilation is already >= need; guard rounding


def floor_tilt(rel: np.ndarray, root: np.ndarray, fps: float, prior_m: float = 0.5, max_deg: float = 20.0) -> torch.Tensor:
    """Rotation ``(4,)`` float64 that levels the floor under the feet that are down along the camera path.

    A plane ``y = a x + b z + c`` is fitted to the contact points, with a ridge toward level
    (equivalent to ``prior_m`` of spread): a person who stays in place leaves the body-axis
    estimate (:func:`up_rotation`) as it is, one who walks around tilts it to the floor they walk
    on. Tilts beyond ``max_deg`` are not trusted (identity)."""
    clear = foot_clearance(rel, root[:, 1])
    c = contact_weights(clear, floor_level(clear, fps)).ravel()
    pts = (root[:, None, :] + rel[:, _FEET]).reshape(-1, 3)
    total = c.sum()
    if total < 3:
        return _IDENTITY.clone()
    centre = (c[:, None] * pts).sum(0) / total
    d = pts - centre
    xz = d[:, [0, 2]]
    a = np.einsum("n,ni,nj->ij", c, xz, xz) + total * prior_m**2 * np.eye(2)
    slope = np.linalg.solve(a, (c[:, None] * xz * d[:, 1:2]).sum(0))
    normal = np.array([-slope[0], 1.0, -slope[1]])
    normal /= np.linalg.norm(normal)
    if math.degrees(math.acos(normal[1])) > max_deg:
        return _IDENTITY.clone()
    return quat.between(torch.from_numpy(normal), _Y_UP)
