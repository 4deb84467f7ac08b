"""Where a motion carries its hands and feet, and drawing a stray one back.

A limb's *place* is the time-mean position of its end joint in the hips' facing frame (the frame of the
feature vector's joint positions: root's ground position subtracted, turned by the facing yaw; the height
stays above the floor). Canonical motions share the canonical body, so places compare across clips.

A style may move a limb from where the content holds it towards where the style example holds it, not
elsewhere: the *stray* of a result's limb is its place's distance from the segment between the content's
place and the example's (:func:`limb_stray`). :func:`guard_limbs` shifts a stray limb's end by a constant
offset in the facing frame (per frame back to the world) and solves its two-bone chain
(:func:`motioncore.cleanup.two_bone_ik`), so the limb's per-frame motion is kept and only its mean moves.
"""
from __future__ import annotations

import torch

from motioncore import quat
from motioncore.cleanup import two_bone_ik
from motioncore.kinematics import fk
from motioncore.motion import Motion
from motioncore.representation import FEATURES, facing_frame
from motioncore.skeleton import CANONICAL, CanonicalSpec

LIMBS = ("Hand_L", "Hand_R", "Foot_L", "Foot_R")  # the end effectors whose carriage a style may change
HANDS = ("Hand_L", "Hand_R")
GUARD_PASSES = 6  # IK passes of guard_limbs: a chain that cannot reach its target on every frame gets the rest again
GUARD_TOLERANCE = 0.005  # metres: a place this close to its target is left alone


def limb_places(feats: torch.Tensor, spec: CanonicalSpec = CANONICAL) -> torch.Tensor:
    """Time-mean place of each of :data:`LIMBS` in the hips' facing frame, ``feats (T, D)`` raw (not
    normalised) model features on the canonical skeleton -> ``(4, 3)`` metres."""
    if feats.ndim != 2 or feats.shape[1] != FEATURES.dim:
        raise ValueError(f"limb_places: expected raw features (T, {FEATURES.dim}), got {tuple(feats.shape)}")
    return _joint_positions(feats, LIMBS, spec).mean(0)


def _joint_positions(feats: torch.Tensor, names: tuple[str, ...], spec: CanonicalSpec) -> torch.Tensor:
    """The facing-frame positions ``(T, len(names), 3)`` of the named joints in raw features ``(T, D)``."""
    pos = feats[:, FEATURES.positions].reshape(feats.shape[0], spec.num_joints - 1, 3)  # joints 1.. (root excluded)
    return pos[:, [spec.skeleton.names.index(n) - 1 for n in names]]


def _facing(gpos: torch.Tensor, spec: CanonicalSpec) -> tuple[torch.Tensor, torch.Tensor]:
    """``gpos (T, J, 3)`` -> the facing yaw ``(T, 4)`` quaternion and each limb end's position ``(T, 4, 3)`` in
    the hips' facing frame (:func:`motioncore.representation.facing_frame`)."""
    theta, rel = facing_frame(gpos, spec)
    return quat.from_yaw(theta), rel[:, [spec.skeleton.index(n) - 1 for n in LIMBS]]


def motion_limb_places(motion: Motion, spec: CanonicalSpec = CANONICAL) -> torch.Tensor:
    """:func:`limb_places` of a canonical motion (from its joints, not its features) -> ``(4, 3)`` metres."""
    if motion.skeleton.names != spec.skeleton.names:
        raise ValueError("motion_limb_places: expected a motion on the canonical skeleton")
    return _facing(motion.global_positions(), spec)[1].mean(0)


def nearest_on_segment(a: torch.Tensor, b: torch.Tensor, p: torch.Tensor) -> torch.Tensor:
    """The point of each segment ``a -> b`` nearest ``p`` (all ``(N, 3)``) -> ``(N, 3)``."""
    if not a.shape == b.shape == p.shape or a.shape[-1] != 3:
        raise ValueError(f"nearest_on_segment: expected a, b, p (N, 3) alike, got {tuple(a.shape)}, "
                         f"{tuple(b.shape)}, {tuple(p.shape)}")
    ab = b - a
    t = ((p - a) * ab).sum(-1) / (ab * ab).sum(-1).clamp_min(1e-12)
    return a + t.clamp(0, 1)[:, None] * ab


def limb_stray(content: torch.Tensor, example: torch.Tensor, result: torch.Tensor) -> torch.Tensor:
    """How far each limb's time-mean place in ``result`` lies from the segment between its place in
    ``content`` and in ``example`` (all raw features ``(T, D)``, any lengths) -> ``(4,)`` metres, in the
    order of :data:`LIMBS`. 0: the style moved the limb from where the content holds it towards where the
    example holds it (or left it); larger: it put the limb somewhere neither holds it."""
    a, b, p = limb_places(content), limb_places(example), limb_places(result)
    return (p - nearest_on_segment(a, b, p)).norm(dim=-1)


def allowed_stray(stray: torch.Tensor, start: float) -> torch.Tensor:
    """The stray :func:`guard_limbs` leaves, ``stray (*)`` metres -> ``(*)``: unchanged up to ``start``, then a
    smooth ramp (slope 1 at ``start``) that never reaches ``1.5 * start``."""
    if start <= 0:
        raise ValueError(f"allowed_stray: expected a start above 0, got {start}")
    width = 0.5 * start
    return torch.where(stray <= start, stray, start + width * torch.tanh((stray - start) / width))


def swing_limb(grot: torch.Tensor, gpos: torch.Tensor, lrot: torch.Tensor, parents, root: int, end: int,
               target: torch.Tensor) -> torch.Tensor:
    """New local rotations ``(T, J, 4)`` turning the chain from joint ``root`` as one piece, frame by frame, so that
    its ``end`` points at ``target (T, 3)`` from ``root``: only ``root``'s rotation changes (the joints below keep
    their local angles; the end's distance from ``root`` stays). ``grot``/``gpos`` ``(T, J, 4/3)`` global."""
    swing = quat.between(gpos[:, end] - gpos[:, root], target - gpos[:, root])
    out = lrot.clone()
    out[:, root] = quat.mul(quat.inv(grot[:, parents[root]]), quat.mul(swing, grot[:, root]))
    return out


def guard_limbs(motion: Motion, content_places: torch.Tensor, example_places: torch.Tensor, start: float,
                spec: CanonicalSpec = CANONICAL, swing_hands: bool = False) -> tuple[Motion, torch.Tensor]:
    """Draw each stray limb of a canonical ``motion`` back towards the segment from ``content_places`` to
    ``example_places`` (both ``(4, 3)``, :func:`limb_places`), so its stray is at most :func:`allowed_stray`
    of ``start`` metres. The limb's end moves by one offset in the facing frame (the feet's horizontal only: the
    foot cleanup keeps them on the floor), its chain solved by two-bone IK (the end keeps its global rotation);
    with ``swing_hands`` an arm is swung at the shoulder instead (:func:`swing_limb`: its elbow and wrist keep
    their angles, so a wave stays a wave).
    Returns the motion (the same object when no limb strays) and the offsets ``(4, 3)`` applied, in metres."""
    if motion.skeleton.names != spec.skeleton.names:
        raise ValueError("guard_limbs: expected a motion on the canonical skeleton")
    if content_places.shape != (len(LIMBS), 3) or example_places.shape != (len(LIMBS), 3):
        raise ValueError(f"guard_limbs: expected places ({len(LIMBS)}, 3), got {tuple(content_places.shape)} and "
                         f"{tuple(example_places.shape)}")
    sk = spec.skeleton
    ends = [sk.index(n) for n in LIMBS]
    chains = [(sk.parents[sk.parents[e]], sk.parents[e], e) for e in ends]
    horizontal = torch.tensor([[1.0, 0.0 if n in _ankles(spec) else 1.0, 1.0] for n in LIMBS])
    a, b = content_places.float(), example_places.float()
    grot, gpos = fk(motion.lrot, motion.lpos, sk.parents)
    yaw, local = _facing(gpos, spec)
    p = local.mean(0)
    nearest = nearest_on_segment(a, b, p)
    stray = (p - nearest).norm(dim=-1)
    target = nearest + (p - nearest) * (allowed_stray(stray, start) / stray.clamp_min(1e-12))[:, None]
    applied = torch.zeros(len(LIMBS), 3)
    lrot = motion.lrot
    for _ in range(GUARD_PASSES):
        shift = (target - p) * horizontal
        todo = [i for i in range(len(LIMBS)) if float(shift[i].norm()) > GUARD_TOLERANCE]
        if not todo:
            break
        for i in todo:
            hip, knee, end = chains[i]
            goal = gpos[:, end] + quat.mul_vec(yaw, shift[i].expand(gpos.shape[0], 3))
            if swing_hands and LIMBS[i] in HANDS:
                lrot = swing_limb(grot, gpos, lrot, sk.parents, hip, end, goal)
            else:
                lrot = two_bone_ik(grot, gpos, lrot, sk.parents, hip, knee, end, goal)
            grot, gpos = fk(lrot, motion.lpos, sk.parents)  # the chains are disjoint; the facing yaw does not move
        yaw, local = _facing(gpos, spec)
        moved = local.mean(0)
        applied += moved - p
        p = moved
    if lrot is motion.lrot:
        return motion, applied
    return Motion(sk, quat.normalize(lrot), motion.lpos, motion.fps), applied


def _ankles(spec: CanonicalSpec) -> tuple[str, ...]:
    """The ankle joints' names (the legs' ends): their places move only horizontally."""
    return tuple(spec.skeleton.names[ankle] for _, _, ankle in spec.legs)


REACH_CHUNK = 4096  # content frames compared with the example at a time: bounds the distance table of a long take


def hand_reach(content: torch.Tensor, example: torch.Tensor, spec: CanonicalSpec = CANONICAL) -> torch.Tensor:
    """How far each hand of ``content`` is, frame by frame, from every place the same hand takes in
    ``example`` (both raw features on the canonical skeleton, ``(T, D)`` and ``(T', D)``; positions in the hips'
    facing frame) -> ``(T, 2)`` metres, left then right. Small where the content holds its hands as the example
    ever does (walks against a walk: under 0.2 m); large where it does what the example never does (hands raised
    over the head against a walk: 0.5-0.8 m)."""
    for name, f in (("content", content), ("example", example)):
        if f.ndim != 2 or f.shape[1] != FEATURES.dim or f.shape[0] < 1:
            raise ValueError(f"hand_reach: expected {name} raw features (T, {FEATURES.dim}), got {tuple(f.shape)}")
    places = _joint_positions(example, HANDS, spec).float().transpose(0, 1)  # (2, T', 3)
    out = []
    for a in range(0, content.shape[0], REACH_CHUNK):
        c = _joint_positions(content[a:a + REACH_CHUNK], HANDS, spec).float().transpose(0, 1)  # (2, t, 3)
        out.append(torch.cdist(c, places, compute_mode="donot_use_mm_for_euclid_dist").amin(-1).T)  # (t, 2)
    return torch.cat(out)
