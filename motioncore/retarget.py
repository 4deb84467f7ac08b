"""Retargeting between the canonical skeleton and real skeletons.

Each skeleton gets a :class:`Rig`: which of its joints plays each canonical joint (found from
the hierarchy and the rest pose by :mod:`motioncore.humanoid`; a user's joint map may override
any of them), the world basis that makes it Y-up, and its "T-pose" -- the global rotation of
every joint in the pose that matches the canonical rest pose (a T-pose facing +Z). A motion
moves to the canonical skeleton by carrying each joint's rotation *relative to its T-pose* (in
the canonical world) onto the matching canonical joint; the root translation is scaled by the
leg-length ratio. Results go back with :func:`carry_edit`, which changes the original motion
only as much as the canonical result differs from the canonical content, so joints without a
role (fingers, twist bones, extra spine joints) and each bone's twist pass through.
"""
from __future__ import annotations

import json
import os
from dataclasses import dataclass

import torch

from motioncore import quat
from motioncore.humanoid import (
    OPTIONAL_ROLES,
    HumanoidMap,
    NotHumanoidError,
    axis_vector,
    decide_up,
    find_humanoid,
    up_axis,
)
from motioncore.kinematics import fk, rest_positions, to_local
from motioncore.motion import Motion
from motioncore.skeleton import CANONICAL, CanonicalSpec, Skeleton


class RetargetError(ValueError):
    pass


CHUNK = 5_000  # frames retargeted at a time: bounds the memory of a long take


MAX_JOINT_MAP_BYTES = 64 * 1024


def load_joint_map(path: str | os.PathLike) -> dict[str, str]:
    """A user map file: a JSON object ``{"Hips": "pelvis", "Spine": "spine_01", ...}``."""
    try:
        with open(path, "rb") as f:
            raw = f.read(MAX_JOINT_MAP_BYTES + 1)
        if len(raw) > MAX_JOINT_MAP_BYTES:
            raise ValueError(f"larger than {MAX_JOINT_MAP_BYTES // 1024} KiB")
        data = json.loads(raw.decode("utf-8-sig"))
    except (OSError, ValueError, RecursionError) as e:  # UnicodeDecodeError and JSONDecodeError are ValueErrors
        reason = "nested too deeply" if isinstance(e, RecursionError) else str(e)[:120]
        raise RetargetError(f"{os.fspath(path)}: cannot read joint map: {reason}") from None
    if not isinstance(data, dict) or not all(isinstance(k, str) and (isinstance(v, str) or v is None) for k, v in data.items()):
        raise RetargetError(f"{os.fspath(path)}: expected a JSON object of canonical joint name -> your joint name (or null)")
    unknown = sorted(set(data) - set(CANONICAL.skeleton.names))
    if unknown:
        raise RetargetError(f"{os.fspath(path)}: not canonical joint names: {', '.join(unknown)}")
    required_null = sorted(k for k, v in data.items() if v is None and k not in OPTIONAL_ROLES)
    if required_null:
        raise RetargetError(f"{os.fspath(path)}: these roles need a joint, null is only for {', '.join(sorted(OPTIONAL_ROLES))}: "
                            f"{', '.join(required_null)}")
    return data


def find_roles(skeleton: Skeleton, sample: Motion | None = None, joint_map: dict[str, str | None] | None = None,
               source: str = "skeleton") -> tuple[tuple[int | None, ...], str, HumanoidMap | None]:
    """For every canonical joint, the index of the joint of ``skeleton`` playing it (None: no such bone).

    Found by :func:`motioncore.humanoid.find_humanoid` (``sample`` helps when the rest pose is not a
    standing pose); ``joint_map`` entries override it and, where it finds nothing, must name every role.
    Returns ``(indices, how: "auto" | "user" | "auto+user", the automatic map or None)``.
    """
    lookup = {n: i for i, n in enumerate(skeleton.names)}
    lookup.update({n.lower(): i for i, n in enumerate(skeleton.names) if n.lower() not in lookup})
    user: dict[str, int | None] = {}
    for role, name in (joint_map or {}).items():
        i = None if name is None else lookup.get(name, lookup.get(name.lower()))
        if name is not None and i is None:
            raise RetargetError(f"{source}: the joint map names {name!r} for {role}, but the skeleton has no such joint")
        user[role] = i
    try:
        auto = find_humanoid(skeleton, *(() if sample is None else (sample.lrot, sample.lpos)))
    except NotHumanoidError as e:
        missing = [r for r in CANONICAL.skeleton.names if r not in user and r not in OPTIONAL_ROLES]
        if joint_map is not None and not missing:
            return tuple(user.get(r) for r in CANONICAL.skeleton.names), "user", None
        raise RetargetError(
            f"{source}: not a humanoid skeleton we can map: {e}. Write a joint map with `video2style skeleton "
            f"{source} --write-map map.json`, fix it, and pass --joint-map map.json"
            + (f" (yours lacks {', '.join(missing)})" if joint_map is not None else "")) from None
    joints = tuple(user.get(r, j) for r, j in zip(CANONICAL.skeleton.names, auto.joints))
    used = [j for j in joints if j is not None]
    if len(set(used)) != len(used):
        twice = sorted({skeleton.names[j] for j in used if used.count(j) > 1})
        raise RetargetError(f"{source}: the joint map gives one joint two roles: {', '.join(twice)}")
    return joints, ("auto+user" if user else "auto"), auto


@dataclass(frozen=True)
class Rig:
    """How one skeleton relates to the canonical skeleton (see the module docstring)."""

    skeleton: Skeleton
    mapping: tuple[int | None, ...]  # skeleton joint index for each canonical joint; None: no such bone
    basis: torch.Tensor  # (4,) rotation from this skeleton's world to the canonical Y-up world
    tpose: torch.Tensor  # (J, 4) global rotations, in the canonical world, of the T-pose
    scale: float  # canonical leg length / this skeleton's leg length
    map_name: str  # "auto", "user" or "auto+user"
    humanoid: HumanoidMap | None = None  # what the automatic mapping found (None: the user's map alone)


def _chain_length(sk: Skeleton, top: int, bottom: int) -> float:
    length, j = 0.0, bottom
    while j != top and j >= 0:
        length += float(sk.offsets[j].norm())
        j = sk.parents[j]
    return length


def mapped_children(mapping: tuple[int | None, ...], c: int, spec: CanonicalSpec = CANONICAL) -> list[int]:
    """The canonical joints nearest below ``c`` that have a bone in ``mapping`` (skipping roles without one)."""
    out = []
    for k in spec.skeleton.children(c):
        out.extend([k] if mapping[k] is not None else mapped_children(mapping, k, spec))
    return out


def up_basis(axis: str) -> torch.Tensor:
    """Rotation ``(4,)`` taking the world axis ``axis`` (``"+Z"``, ...) to +Y."""
    return quat.between(axis_vector(axis).float(), torch.tensor([0.0, 1.0, 0.0]))


def detect_up_basis(gpos: torch.Tensor, hips: int, head: int) -> torch.Tensor:
    """Rotation ``(4,)`` taking the up axis of ``gpos (T, J, 3)`` (:func:`motioncore.humanoid.up_axis`: the
    axis nearest the mean hips->head direction) to +Y."""
    return up_basis(up_axis(gpos, hips, head))


def make_rig(
    skeleton: Skeleton,
    sample: Motion | None = None,
    joint_map: dict[str, str | None] | None = None,
    spec: CanonicalSpec = CANONICAL,
    source: str = "skeleton",
) -> Rig:
    """Build the :class:`Rig` of ``skeleton`` (roles: :func:`find_roles`); ``sample`` (a motion on it) decides
    which axis is up, else the rest pose does."""
    mapping, map_name, humanoid = find_roles(skeleton, sample, joint_map, source)
    canon = spec.skeleton
    hips, head = mapping[0], mapping[canon.index("Head")]
    if skeleton.names == canon.names:
        basis = quat.identity()
    elif humanoid is not None and (humanoid.joint("Hips"), humanoid.joint("Head")) == (hips, head):
        basis = up_basis(humanoid.up)  # decided once, by find_humanoid (over the clip when there is one)
    else:  # a joint map names other hips or head: the same decision on them
        feet = tuple(mapping[canon.index(f)] for f in ("Foot_L", "Foot_R"))
        basis = up_basis(decide_up(skeleton, hips, head, *(() if sample is None else (sample.lrot, sample.lpos)),
                                   feet=feet))
    rest = rest_positions(skeleton.offsets.double(), skeleton.parents)
    canon_rest = rest_positions(canon.offsets.double(), canon.parents)
    of = {s: c for c, s in enumerate(mapping) if s is not None}  # skeleton joint -> canonical joint
    b = basis.double()
    world = [None] * skeleton.num_joints
    for s in range(skeleton.num_joints):
        parent = world[skeleton.parents[s]] if s > 0 else b
        c = of.get(s)
        kids = mapped_children(mapping, c, spec) if c is not None else []
        if not kids:
            world[s] = parent
            continue
        src = torch.stack([quat.mul_vec(b, rest[mapping[k]] - rest[s]) for k in kids])
        dst = torch.stack([canon_rest[k] - canon_rest[c] for k in kids])
        if len(kids) == 1:
            cur = quat.mul_vec(quat.mul(parent, quat.inv(b)), src[0])
            world[s] = quat.mul(quat.between(cur, dst[0]), parent)
        else:
            w = torch.ones(len(kids), dtype=torch.float64)
            world[s] = quat.mul(quat.fit_rotation(src[None], dst[None], w[None])[0], b)
    tpose = torch.stack(world).float()
    (hl, _kl, al) = spec.legs[0]
    leg_canon = _chain_length(canon, hl, al)
    leg_src = _chain_length(skeleton, mapping[hl], mapping[al])
    if leg_src <= 0:
        raise RetargetError(f"{source}: the leg joints have zero length; cannot scale")
    return Rig(skeleton, tuple(mapping), basis.float(), tpose, leg_canon / leg_src, map_name, humanoid)


def to_canonical(motion: Motion, rig: Rig, spec: CanonicalSpec = CANONICAL) -> Motion:
    """A motion on ``rig.skeleton`` -> the same motion on the canonical skeleton (same fps).

    A role without a bone (no clavicle, no toe joint) keeps its canonical parent's world rotation.
    """
    if motion.skeleton.names != rig.skeleton.names:
        raise RetargetError("to_canonical: the motion's skeleton is not the rig's skeleton")
    b = rig.basis
    n = motion.num_frames
    g_canon = torch.empty(n, spec.num_joints, 4)
    lpos = spec.skeleton.offsets.expand(n, -1, -1).clone()
    for a in range(0, n, CHUNK):  # a long take a chunk of frames at a time: memory stays bounded
        grot, gpos = fk(motion.lrot[a:a + CHUNK], motion.lpos[a:a + CHUNK], motion.skeleton.parents)
        g = []  # canonical global = B * G_src * T_src^-1  (the canonical T-pose is its rest)
        for c, s in enumerate(rig.mapping):
            g.append(g[spec.skeleton.parents[c]] if s is None else quat.mul(quat.mul(b, grot[:, s]), quat.inv(rig.tpose[s])))
        g_canon[a:a + CHUNK] = torch.stack(g, dim=1)
        lpos[a:a + CHUNK, 0] = quat.mul_vec(b, gpos[:, rig.mapping[0]]) * rig.scale
    lrot = to_local(quat.unroll(g_canon, dim=0), spec.skeleton.parents)
    return Motion(spec.skeleton, lrot, lpos, motion.fps)


def from_canonical(motion: Motion, rig: Rig, spec: CanonicalSpec = CANONICAL) -> Motion:
    """A canonical motion -> the same motion on ``rig.skeleton`` (its offsets, same fps); joints without a
    role follow their parent at their T-pose. To change a motion the skeleton already has, keeping what
    the canonical skeleton lacks (fingers, twist), use :func:`carry_edit`."""
    if motion.skeleton.names != spec.skeleton.names:
        raise RetargetError("from_canonical: expected a motion on the canonical skeleton")
    sk = rig.skeleton
    t = motion.num_frames
    g_canon, _ = fk(motion.lrot, spec.skeleton.offsets.expand(t, -1, -1), spec.skeleton.parents)
    of = {s: c for c, s in enumerate(rig.mapping) if s is not None}
    binv = quat.inv(rig.basis)
    delta = [None] * sk.num_joints  # world-space rotation relative to the T-pose
    grot = []
    for s in range(sk.num_joints):
        c = of.get(s)
        if c is not None:
            delta[s] = g_canon[:, c]
        else:
            delta[s] = delta[sk.parents[s]] if s > 0 else quat.identity(t)
        grot.append(quat.mul(binv, quat.mul(delta[s], rig.tpose[s])))
    grot = quat.unroll(torch.stack(grot, dim=1), dim=0)
    lrot = to_local(grot, sk.parents)
    lpos = sk.offsets.expand(t, -1, -1).clone()
    hips = rig.mapping[0]
    hips_world = quat.mul_vec(binv, motion.lpos[:, 0]) / rig.scale
    if hips == 0:
        lpos[:, 0] = hips_world
    else:  # joints above the hips (Bandai's joint_Root, UE's root) carry them: move the root, the only joint
        _, g_pos = fk(lrot, lpos, sk.parents)  # a BVH file surely gives position channels
        lpos[:, 0] += hips_world - g_pos[:, hips]
    return Motion(sk, lrot, lpos, motion.fps)


def bone_axes(skeleton: Skeleton) -> torch.Tensor:
    """Each joint's bone direction in its rest frame, ``(J, 3)`` unit vectors, the way Blender's BVH importer
    draws bones: toward the one child, toward the mean of several children, along the End Site; +Y where that
    is empty, and a bone that still has no length continues its parent's bone."""
    sk = skeleton
    off = sk.offsets.double()
    tail = []  # Blender's rest_tail_local - rest_head_local
    vec = []  # the bone as drawn, before the zero-length fixes
    for j in range(sk.num_joints):
        kids = sk.children(j)
        if not kids:
            v = sk.end_sites.get(j, torch.zeros(3)).double()
            t = v
        elif len(kids) == 1:
            v = t = off[kids[0]]
        else:  # Blender averages the children's offsets into the tail but compares it with the joint's own
            v = off[kids].mean(0)
            t = v - off[j]
        if float(t.norm()) <= 1e-5:
            v = v + torch.tensor([0.0, 1e-3, 0.0], dtype=torch.float64)
        tail.append(t)
        vec.append(v)
    out = []
    for j in range(sk.num_joints):
        v = vec[j]
        if float(v.norm()) < 1e-6:
            p = sk.parents[j]
            v = tail[p] if p >= 0 and float(tail[p].norm()) > 1e-9 else torch.tensor([0.0, 1.0, 0.0], dtype=torch.float64)
        out.append(v / v.norm())
    return torch.stack(out)


def canonical_change(before: Motion, after: Motion) -> tuple[torch.Tensor, torch.Tensor]:
    """World-space change from ``before`` to ``after`` (canonical, same frames): each joint's rotation
    ``(T, 21, 4)`` and the hips' displacement ``(T, 3)``."""
    if before.num_frames != after.num_frames:
        raise RetargetError(f"canonical_change: expected motions with the same frames, got {before.num_frames} "
                            f"and {after.num_frames}")
    parents = before.skeleton.parents
    rot_b, pos_b = fk(before.lrot, before.lpos, parents)
    rot_a, pos_a = fk(after.lrot, after.lpos, parents)
    return quat.mul(rot_a, quat.inv(rot_b)), pos_a[:, 0] - pos_b[:, 0]


def carry_edit(original: Motion, before: Motion, after: Motion, rig: Rig, offset: float = 0.0) -> Motion:
    """``original`` (on ``rig.skeleton``) changed the way ``after`` differs from ``before``.

    ``before`` is ``original`` on the canonical skeleton (any fps, e.g. resampled to 20) and ``after`` an
    edit of it with the same frames, such as a styled version. The Hips turn in the world by their canonical
    joint's whole change (:func:`canonical_change`: the figure's heading and tilt); every other joint with a
    role by the swing part of it about its own bone (:func:`bone_axes`): the edit may bend a bone, never spin
    it, so each bone keeps the original's twist. Joints
    without a role (fingers, twist bones, extra spine joints, toe ends) keep their local rotations, every
    joint keeps its local offsets, and the root moves with the hips. The result has ``original``'s
    skeleton, frames and fps. ``offset``: where ``original``'s first frame lies in ``before``'s frames (a span
    of a long take: ``before`` and ``after`` may start earlier, by this many of their frames).
    """
    if original.skeleton.names != rig.skeleton.names:
        raise RetargetError("carry_edit: the motion's skeleton is not the rig's skeleton")
    change, shift = canonical_change(before, after)
    # the change at each of the original's frame times
    t = (torch.arange(original.num_frames, dtype=torch.float64) * (before.fps / original.fps) + offset).clamp(
        min=0, max=before.num_frames - 1)
    i0 = t.floor().long()
    i1 = (i0 + 1).clamp(max=before.num_frames - 1)
    w = (t - i0).float()
    change = quat.slerp(change[i0], change[i1], w[:, None])
    shift = torch.lerp(shift[i0], shift[i1], w[:, None])
    sk = rig.skeleton
    axes = bone_axes(sk).float()
    b, binv = rig.basis, quat.inv(rig.basis)
    of = {s: c for c, s in enumerate(rig.mapping) if s is not None}
    lrot = torch.empty_like(original.lrot)
    for a in range(0, original.num_frames, CHUNK):  # a long take a chunk of frames at a time
        z = slice(a, a + CHUNK)
        grot, _ = fk(original.lrot[z], original.lpos[z], sk.parents)
        new = []
        for s in range(sk.num_joints):
            c = of.get(s)
            if c == 0:
                new.append(quat.mul(quat.mul(binv, quat.mul(change[z, c], b)), grot[:, s]))
            elif c is not None:
                axis = quat.mul_vec(grot[:, s], axes[s])  # the bone in the world, as the original has it
                turned = quat.mul_vec(quat.mul(binv, quat.mul(change[z, c], b)), axis)
                new.append(quat.mul(quat.between(axis, turned), grot[:, s]))
            else:
                new.append(grot[:, s] if s == 0 else quat.mul(new[sk.parents[s]], original.lrot[z, s]))
        lrot[z] = to_local(torch.stack(new, dim=1), sk.parents)
    lrot = quat.unroll(lrot, dim=0)
    lpos = original.lpos.clone()
    lpos[:, 0] += quat.mul_vec(binv, shift) / rig.scale
    return Motion(sk, lrot, lpos, original.fps)


def lowest_feet(motion: Motion, spec: CanonicalSpec = CANONICAL) -> torch.Tensor:
    """Per frame ``(T,)``, the lowest foot's toe-level height of a canonical motion (:func:`place_on_floor`'s
    input; a long take's is gathered a span at a time)."""
    gpos = motion.global_positions()
    rest = rest_positions(spec.skeleton.offsets, spec.skeleton.parents)
    feet = list(spec.feet)
    clearance = gpos[:, feet, 1] - (rest[feet, 1] - rest[feet, 1].min())  # (T, 4) toe-level estimate
    return clearance.min(dim=1).values


def floor_shift(lowest: torch.Tensor, spec: CanonicalSpec = CANONICAL, percentile: float = 0.05) -> torch.Tensor:
    """How far :func:`place_on_floor` lowers the root, from every frame's :func:`lowest_feet` ``(T,)``."""
    rest = rest_positions(spec.skeleton.offsets, spec.skeleton.parents)
    feet = list(spec.feet)
    return torch.quantile(lowest, percentile) - (rest[feet, 1].min() - rest[:, 1].min())


def place_on_floor(motion: Motion, spec: CanonicalSpec = CANONICAL, percentile: float = 0.05) -> Motion:
    """Shift a canonical motion vertically so its feet meet y = 0 (robust to a few low frames)."""
    shift = floor_shift(lowest_feet(motion, spec), spec, percentile)
    lpos = motion.lpos.clone()
    lpos[:, 0, 1] -= shift
    return Motion(motion.skeleton, motion.lrot, lpos, motion.fps)
