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

    def joint_channels(self, joints: list[int]) -> list[int]:
        """The channels of the given joints (indices into the skeleton): their root-relative positions (joints
        after the root; the root has none) and their 6D rotations, in that order."""
        bad = [j for j in joints if not 0 <= j < self.num_joints]
        if bad:
            raise ValueError(f"joint_channels: expected joints in 0..{self.num_joints - 1}, got {bad}")
        pos = [self.positions.start + 3 * (j - 1) + k for j in joints if j > 0 for k in range(3)]
        rot = [self.rotations.start + 6 * j + k for j in joints for k in range(6)]
        return pos + rot


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


def facing_frame(gpos: torch.Tensor, spec: CanonicalSpec = CANONICAL) -> tuple[torch.Tensor, torch.Tensor]:
    """The hips' facing frame of ``gpos (T, J, 3)``: the facing yaw ``(T,)`` (:func:`facing_angle`) and joints
    1.. in that frame ``(T, J-1, 3)`` (the root's ground position subtracted, turned by minus the yaw), as the
    feature vector's joint-position channels hold them."""
    theta = facing_angle(gpos, spec)
    rel = gpos[:, 1:] - gpos[:, :1] * gpos.new_tensor([1.0, 0.0, 1.0])
    return theta, quat.mul_vec(quat.from_yaw(-theta)[:, None], rel)


def foot_contacts(gpos: torch.Tensor, fps: float, spec: CanonicalSpec = CANONICAL,
                  floor: torch.Tensor | None = None) -> torch.Tensor:
    """Contact flags ``(T, 4)`` for (Foot_L, Toes_L, Foot_R, Toes_R) from height and speed. ``floor (4,)``: each
    foot joint's lowest height over the take (default: over ``gpos``; a span of a long take gives the take's)."""
    feet = gpos[:, list(spec.feet)]  # (T, 4, 3)
    vel = torch.zeros_like(feet)
    if feet.shape[0] > 1:
        vel[:-1] = (feet[1:] - feet[:-1]) * fps
        vel[-1] = vel[-2]
    floor = feet[..., 1].amin(0, keepdim=True) if floor is None else floor.to(feet.dtype)[None]
    rest_height = _rest_foot_heights(spec)
    height = feet[..., 1] - floor - (rest_height - rest_height.min())
    return ((height < CONTACT_HEIGHT) & (vel.norm(dim=-1) < CONTACT_SPEED)).float()


def _rest_foot_heights(spec: CanonicalSpec) -> torch.Tensor:
    rest = rest_positions(spec.skeleton.offsets, spec.skeleton.parents)
    return rest[list(spec.feet), 1]


CHUNK = 5_000  # frames encoded or decoded at a time: bounds the float64 temporaries of a long clip


def encode(motion: Motion, spec: CanonicalSpec = CANONICAL, floor: torch.Tensor | None = None) -> torch.Tensor:
    """Canonical motion -> features ``(T, D)`` float32. Bone lengths come from the canonical skeleton.
    ``floor (4,)``: the foot joints' lowest heights for the contact channels (default: ``motion``'s own; a
    span of a long take gives the take's, see :func:`foot_contacts`)."""
    if motion.skeleton.names != spec.skeleton.names:
        raise ValueError("encode: expected a motion on the canonical skeleton (retarget it first)")
    n = motion.num_frames
    if n < 2:
        raise ValueError(f"encode: expected at least 2 frames, got {n}")
    fs = FeatureSpec(spec.num_joints)
    out = torch.empty(n, fs.dim)
    feet_y = torch.empty(n, len(spec.feet), dtype=torch.float64)
    speed = torch.empty(n, len(spec.feet), dtype=torch.float64)
    for a in range(0, n, CHUNK):  # each chunk with a frame either side, for the frame-to-frame differences
        b = min(a + CHUNK, n)
        s, e = max(a - 1, 0), min(b + 1, n)
        lrot = motion.lrot[s:e].double()
        lpos = spec.skeleton.offsets.double().expand(e - s, -1, -1).clone()
        lpos[:, 0] = motion.lpos[s:e, 0].double()
        grot, gpos = fk(lrot, lpos, spec.skeleton.parents)
        theta, rel = facing_frame(gpos, spec)  # (t,), (t, J-1, 3)
        yaw_inv = quat.from_yaw(-theta)  # (t, 4)
        root = gpos[:, 0]
        dtheta = _forward_difference(theta, lambda d: torch.remainder(d + torch.pi, 2 * torch.pi) - torch.pi)
        lvel = quat.mul_vec(yaw_inv, _forward_difference(root))[:, [0, 2]]
        lrot[:, 0] = quat.mul(yaw_inv, grot[:, 0])
        rot6 = quat.to_6d(lrot)
        feet = gpos[:, list(spec.feet)]
        keep = slice(a - s, b - s)
        feet_y[a:b] = feet[keep, :, 1]
        speed[a:b] = (_forward_difference(feet) * motion.fps).norm(dim=-1)[keep]
        out[a:b, : fs.contacts.start] = torch.cat(
            [dtheta[:, None], lvel, root[:, 1:2], rel.flatten(1), rot6.flatten(1)], dim=1)[keep].float()
    out[:, fs.contacts] = _contacts(feet_y, speed, spec, floor).float()
    return out


def _forward_difference(x: torch.Tensor, wrap=None) -> torch.Tensor:
    """``x[t + 1] - x[t]`` along dim 0, the last frame repeating the one before it."""
    d = x[1:] - x[:-1]
    d = wrap(d) if wrap is not None else d
    return torch.cat([d, d[-1:]])


def _contacts(feet_y: torch.Tensor, speed: torch.Tensor, spec: CanonicalSpec,
              floor: torch.Tensor | None = None) -> torch.Tensor:
    floor = feet_y.amin(0, keepdim=True) if floor is None else floor.to(feet_y.dtype)[None]
    rest_height = _rest_foot_heights(spec)
    height = feet_y - floor - (rest_height - rest_height.min())
    return ((height < CONTACT_HEIGHT) & (speed < CONTACT_SPEED)).double()


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
    t = feats.shape[0]
    theta = torch.zeros(t, dtype=torch.float64)
    theta[1:] = torch.cumsum(feats[:-1, fs.root_rvel][:, 0].double(), 0)
    theta = theta + start_yaw
    yaw = quat.from_yaw(theta)
    lvel = torch.zeros(t, 3, dtype=torch.float64)
    lvel[:, [0, 2]] = feats[:, fs.root_lvel].double()
    step = quat.mul_vec(yaw, lvel)
    root = torch.zeros(t, 3, dtype=torch.float64)
    root[1:] = torch.cumsum(step[:-1], 0)
    root[:, 0] += start_xz[0]
    root[:, 2] += start_xz[1]
    root[:, 1] = feats[:, fs.root_height][:, 0].double()

    lrot = torch.empty(t, spec.num_joints, 4)
    for a in range(0, t, CHUNK):
        part = quat.from_6d(feats[a:a + CHUNK, fs.rotations].double().reshape(-1, spec.num_joints, 6))
        part[:, 0] = quat.mul(yaw[a:a + CHUNK], part[:, 0])
        lrot[a:a + CHUNK] = part.float()
    lpos = spec.skeleton.offsets.expand(t, -1, -1).clone()
    lpos[:, 0] = root.float()
    return Motion(spec.skeleton, lrot, lpos, fps)


def decode_positions(feats: torch.Tensor, spec: CanonicalSpec = CANONICAL, start_yaw: float = 0.0,
                     dtype: torch.dtype | None = None) -> torch.Tensor:
    """Global positions ``(*, T, J, 3)`` from the position features (not the rotations), differentiable.

    ``dtype`` (default: the features'): the precision to compute in, e.g. float64 from float32 features without
    a converted copy of them all; the same values as ``decode_positions(feats.to(dtype))``. A clip ``(T, D)``
    longer than :data:`CHUNK` frames that needs no gradient has its root path integrated over the whole clip and
    its joints placed :data:`CHUNK` frames at a time (a long take's temporaries stay small)."""
    fs = FeatureSpec(spec.num_joints)
    if feats.shape[-1] != fs.dim:
        raise ValueError(f"decode_positions: expected (*, T, {fs.dim}), got {tuple(feats.shape)}")
    dtype = dtype or feats.dtype

    def column(i: int) -> torch.Tensor:
        return feats[..., i].to(dtype)

    rvel = column(fs.root_rvel.start)
    theta = torch.cumsum(rvel, -1) - rvel + start_yaw
    yaw = quat.from_yaw(theta)
    lvel = torch.stack([column(fs.root_lvel.start), torch.zeros_like(rvel), column(fs.root_lvel.start + 1)], -1)
    step = quat.mul_vec(yaw, lvel)
    root = torch.cumsum(step, -2) - step
    hips = root + torch.stack([torch.zeros_like(rvel), column(fs.root_height.start), torch.zeros_like(rvel)], -1)
    if feats.ndim != 2 or feats.shape[0] <= CHUNK or (torch.is_grad_enabled() and feats.requires_grad):
        return _place_joints(feats, spec, yaw, root, hips, dtype)
    out = torch.empty(feats.shape[0], spec.num_joints, 3, dtype=dtype, device=feats.device)
    for a in range(0, feats.shape[0], CHUNK):
        out[a:a + CHUNK] = _place_joints(feats[a:a + CHUNK], spec, yaw[a:a + CHUNK], root[a:a + CHUNK],
                                         hips[a:a + CHUNK], dtype)
    return out


def positions_from_rotations(feats: torch.Tensor, spec: CanonicalSpec = CANONICAL) -> torch.Tensor:
    """Joints 1.. in the hips' facing frame ``(*, T, J-1, 3)``, as the position channels hold them, but implied by
    the rotation channels and the root height of ``feats (*, T, D)`` through forward kinematics on the canonical
    bones (differentiable). On features that :func:`encode` wrote, it equals their position channels."""
    fs = FeatureSpec(spec.num_joints)
    if feats.shape[-1] != fs.dim:
        raise ValueError(f"positions_from_rotations: expected (*, T, {fs.dim}), got {tuple(feats.shape)}")
    lrot = quat.from_6d(feats[..., fs.rotations].unflatten(-1, (spec.num_joints, 6)))
    lpos = spec.skeleton.offsets.to(feats).expand(*lrot.shape[:-1], 3)
    height = feats[..., fs.root_height]
    root = torch.cat([torch.zeros_like(height), height, torch.zeros_like(height)], -1)
    lpos = torch.cat([root[..., None, :], lpos[..., 1:, :]], dim=-2)
    return fk(lrot, lpos, spec.skeleton.parents)[1][..., 1:, :]


def feet_velocity(feats: torch.Tensor, rel: torch.Tensor | None = None, spec: CanonicalSpec = CANONICAL) -> torch.Tensor:
    """How far each contact joint (:attr:`CanonicalSpec.feet`) moves from frame t to t+1 over the ground, in the
    facing frame of frame t, metres ``(*, T-1, 4, 3)``: the root's planar step plus the joint's move about the
    root, turned by the frame's yaw step (``root_lvel``, ``root_rvel`` of ``feats (*, T, D)``). ``rel (*, T, J-1, 3)``:
    the joints about the root to use (default: the position channels; e.g. :func:`positions_from_rotations`'
    for what the rotation channels imply). Differentiable; zero for a foot planted on the ground."""
    fs = FeatureSpec(spec.num_joints)
    if feats.shape[-1] != fs.dim or feats.shape[-2] < 2:
        raise ValueError(f"feet_velocity: expected (*, T >= 2, {fs.dim}), got {tuple(feats.shape)}")
    if rel is None:
        rel = feats[..., fs.positions].unflatten(-1, (spec.num_joints - 1, 3))
    if rel.shape != (*feats.shape[:-1], spec.num_joints - 1, 3):
        raise ValueError(f"feet_velocity: expected rel {(*feats.shape[:-1], spec.num_joints - 1, 3)}, got {tuple(rel.shape)}")
    feet = rel[..., [j - 1 for j in spec.feet], :]  # (*, T, 4, 3)
    turn = quat.from_yaw(feats[..., :-1, fs.root_rvel.start])[..., None, :]  # (*, T-1, 1, 4)
    lvel = feats[..., :-1, fs.root_lvel]
    step = torch.stack([lvel[..., 0], torch.zeros_like(lvel[..., 0]), lvel[..., 1]], -1)[..., None, :]
    return step + quat.mul_vec(turn, feet[..., 1:, :, :]) - feet[..., :-1, :, :]


def _place_joints(feats: torch.Tensor, spec: CanonicalSpec, yaw: torch.Tensor, root: torch.Tensor,
                  hips: torch.Tensor, dtype: torch.dtype) -> torch.Tensor:
    """:func:`decode_positions`' per-frame part: the joints of ``feats (*, T, D)`` around the root path."""
    rel = feats[..., FeatureSpec(spec.num_joints).positions].to(dtype).unflatten(-1, (spec.num_joints - 1, 3))
    rel = quat.mul_vec(yaw[..., None, :], rel) + root[..., None, :]
    return torch.cat([hips[..., None, :], rel], dim=-2)
