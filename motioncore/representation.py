"""The model's motion features after Hu et al. 2024 §3.1, on the canonical skeleton.

Per frame: root yaw angular velocity, root planar velocity in the facing frame, root height,
root-relative joint positions in the facing frame (J-1 joints), local 6D rotations with the
root's localised by the facing direction, and four foot-contact flags. The slices live in
:data:`FEATURES`; nothing else in the project writes literal offsets into this vector.

Velocities at frame t are ``x[t+1] - x[t]`` (the last frame repeats the previous one), so
integrating them reproduces the root path exactly.
"""
from __future__ import annotations

from dataclasses import dataclass

import torch

from motioncore import quat
from motioncore.kinematics import fk, rest_positions
from motioncore.motion import Motion
from motioncore.skeleton import CANONICAL, CanonicalSpec


@dataclass(frozen=True)
class FeatureSpec:
    """Layout of the ``(T, D)`` feature vector."""

    num_joints: int

    @property
    def root_rvel(self) -> slice:
        return slice(0, 1)

    @property
    def root_lvel(self) -> slice:
        return slice(1, 3)

    @property
    def root_height(self) -> slice:
        return slice(3, 4)

    @property
    def positions(self) -> slice:
        return slice(4, 4 + 3 * (self.num_joints - 1))

    @property
    def rotations(self) -> slice:
        start = self.positions.stop
        return slice(start, start + 6 * self.num_joints)

    @property
    def contacts(self) -> slice:
        start = self.rotations.stop
        return slice(start, start + 4)

    @property
    def dim(self) -> int:
        return self.contacts.stop


FEATURES = FeatureSpec(CANONICAL.num_joints)

CONTACT_HEIGHT = 0.06  # metres above the clip's lowest foot level (ankle joints sit higher: see offset)
CONTACT_SPEED = 0.35  # metres per second


def facing_angle(gpos: torch.Tensor, spec: CanonicalSpec = CANONICAL) -> torch.Tensor:
    """Yaw of the body's forward direction, ``gpos (*, J, 3) -> (*)``; 0 means facing +Z.

    Forward is the cross product of the left-minus-right hip and shoulder vectors with +Y
    (as in PFNN), which for a person facing +Z with the left side at +X gives +Z.
    """
    (hl, hr), (sl, sr) = spec.hips_lr, spec.shoulders_lr
    across = (gpos[..., hl, :] - gpos[..., hr, :]) + (gpos[..., sl, :] - gpos[..., sr, :])
    return torch.atan2(-across[..., 2], across[..., 0])  # forward = across x up = (-a_z, 0, a_x)


def foot_contacts(gpos: torch.Tensor, fps: float, spec: CanonicalSpec = CANONICAL) -> torch.Tensor:
    """Contact flags ``(T, 4)`` for (Foot_L, Toes_L, Foot_R, Toes_R) from height and speed."""
    feet = gpos[:, list(spec.feet)]  # (T, 4, 3)
    vel = torch.zeros_like(feet)
    if feet.shape[0] > 1:
        vel[:-1] = (feet[1:] - feet[:-1]) * fps
        vel[-1] = vel[-2]
    floor = feet[..., 1].amin(0, keepdim=True)
    rest_height = _rest_foot_heights(spec)
    height = feet[..., 1] - floor - (rest_height - rest_height.min())
    return ((height < CONTACT_HEIGHT) & (vel.norm(dim=-1) < CONTACT_SPEED)).float()


def _rest_foot_heights(spec: CanonicalSpec) -> torch.Tensor:
    rest = rest_positions(spec.skeleton.offsets, spec.skeleton.parents)
    return rest[list(spec.feet), 1]


def encode(motion: Motion, spec: CanonicalSpec = CANONICAL) -> torch.Tensor:
    """Canonical motion -> features ``(T, D)`` float32. Bone lengths come from the canonical skeleton."""
    if motion.skeleton.names != spec.skeleton.names:
        raise ValueError("encode: expected a motion on the canonical skeleton (retarget it first)")
    if motion.num_frames < 2:
        raise ValueError(f"encode: expected at least 2 frames, got {motion.num_frames}")
    lrot = motion.lrot.double()
    lpos = spec.skeleton.offsets.double().expand(motion.num_frames, -1, -1).clone()
    lpos[:, 0] = motion.lpos[:, 0].double()
    grot, gpos = fk(lrot, lpos, spec.skeleton.parents)
    theta = facing_angle(gpos, spec)  # (T,)
    yaw_inv = quat.from_yaw(-theta)  # (T, 4)
    root = gpos[:, 0]

    dtheta = torch.zeros_like(theta)
    dtheta[:-1] = torch.remainder(theta[1:] - theta[:-1] + torch.pi, 2 * torch.pi) - torch.pi
    dtheta[-1] = dtheta[-2]
    droot = torch.zeros_like(root)
    droot[:-1] = root[1:] - root[:-1]
    droot[-1] = droot[-2]
    lvel = quat.mul_vec(yaw_inv, droot)[:, [0, 2]]

    rel = gpos[:, 1:] - root[:, None] * root.new_tensor([1.0, 0.0, 1.0])
    rel = quat.mul_vec(yaw_inv[:, None], rel)

    lrot_local = lrot.clone()
    lrot_local[:, 0] = quat.mul(yaw_inv, grot[:, 0])
    rot6 = quat.to_6d(lrot_local)

    contacts = foot_contacts(gpos, motion.fps, spec).double()
    feats = torch.cat(
        [dtheta[:, None], lvel, root[:, 1:2], rel.flatten(1), rot6.flatten(1), contacts], dim=1
    )
    return feats.float()


def decode(
    feats: torch.Tensor,
    fps: float = CANONICAL.fps,
    spec: CanonicalSpec = CANONICAL,
    start_yaw: float = 0.0,
    start_xz: tuple[float, float] = (0.0, 0.0),
) -> Motion:
    """Features ``(T, D)`` -> canonical :class:`Motion`, integrating the root from ``start_*``."""
    fs = FeatureSpec(spec.num_joints)
    if feats.ndim != 2 or feats.shape[1] != fs.dim:
        raise ValueError(f"decode: expected features (T, {fs.dim}), got {tuple(feats.shape)}")
    f = feats.double()
    t = f.shape[0]
    theta = torch.zeros(t, dtype=torch.float64)
    theta[1:] = torch.cumsum(f[:-1, fs.root_rvel][:, 0], 0)
    theta = theta + start_yaw
    yaw = quat.from_yaw(theta)
    lvel = torch.zeros(t, 3, dtype=torch.float64)
    lvel[:, [0, 2]] = f[:, fs.root_lvel]
    step = quat.mul_vec(yaw, lvel)
    root = torch.zeros(t, 3, dtype=torch.float64)
    root[1:] = torch.cumsum(step[:-1], 0)
    root[:, 0] += start_xz[0]
    root[:, 2] += start_xz[1]
    root[:, 1] = f[:, fs.root_height][:, 0]

    lrot = quat.from_6d(f[:, fs.rotations].reshape(t, spec.num_joints, 6))
    lrot[:, 0] = quat.mul(yaw, lrot[:, 0])
    lpos = spec.skeleton.offsets.double().expand(t, -1, -1).clone()
    lpos[:, 0] = root
    return Motion(spec.skeleton, lrot.float(), lpos.float(), fps)


def decode_positions(feats: torch.Tensor, spec: CanonicalSpec = CANONICAL, start_yaw: float = 0.0) -> torch.Tensor:
    """Global positions ``(*, T, J, 3)`` from the position features (not the rotations), differentiable."""
    fs = FeatureSpec(spec.num_joints)
    if feats.shape[-1] != fs.dim:
        raise ValueError(f"decode_positions: expected (*, T, {fs.dim}), got {tuple(feats.shape)}")
    rvel = feats[..., fs.root_rvel.start]
    theta = torch.cumsum(rvel, -1) - rvel + start_yaw
    yaw = quat.from_yaw(theta)
    lvel = torch.stack([feats[..., fs.root_lvel.start], torch.zeros_like(rvel), feats[..., fs.root_lvel.start + 1]], -1)
    step = quat.mul_vec(yaw, lvel)
    root = torch.cumsum(step, -2) - step
    rel = feats[..., fs.positions].unflatten(-1, (spec.num_joints - 1, 3))
    rel = quat.mul_vec(yaw[..., None, :], rel) + root[..., None, :]
    hips = root + torch.stack([torch.zeros_like(rvel), feats[..., fs.root_height.start], torch.zeros_like(rvel)], -1)
    return torch.cat([hips[..., None, :], rel], dim=-2)
