"""Retargeting between the canonical skeleton and real skeletons.

Each skeleton gets a :class:`Rig`: which of its joints plays each canonical joint, the
world basis that makes it Y-up, and its "T-pose" -- the global rotation of every joint in
the pose that matches the canonical rest pose (a T-pose facing +Z). A motion moves from one
skeleton to another by carrying each joint's rotation *relative to its T-pose* (in the
canonical world) onto the matching joint of the other skeleton. Unmapped joints follow their
nearest mapped ancestor rigidly. The root translation is scaled by the leg-length ratio.
"""
from __future__ import annotations

import json
import os
from dataclasses import dataclass

import torch

from motioncore import quat
from motioncore.kinematics import fk, rest_positions, to_local
from motioncore.motion import Motion
from motioncore.skeleton import CANONICAL, CanonicalSpec, Skeleton

_SIDES = {"L": "Left", "R": "Right"}


def _limbs(fmt: dict[str, str]) -> dict[str, str]:
    """Arm and leg entries for both sides from ``{"Shoulder": "{Side}Shoulder", ...}``."""
    out = {}
    for s, side in _SIDES.items():
        for canon, pattern in fmt.items():
            out[f"{canon}_{s}"] = pattern.format(Side=side, S=s, s=s.lower(), side=side.lower())
    return out


_CMU_LIMBS = {
    "Shoulder": "{Side}Shoulder", "UpperArm": "{Side}Arm", "LowerArm": "{Side}ForeArm", "Hand": "{Side}Hand",
    "UpperLeg": "{Side}UpLeg", "LowerLeg": "{Side}Leg", "Foot": "{Side}Foot", "Toes": "{Side}ToeBase",
}

JOINT_MAPS: dict[str, dict[str, str]] = {
    # canonical joint -> source joint
    "bandai": {n: n for n in CANONICAL.skeleton.names},
    "cmu": {"Hips": "Hips", "Spine": "Spine", "Chest": "Spine1", "Neck": "Neck1", "Head": "Head", **_limbs(_CMU_LIMBS)},
    "animated_drawings": {"Hips": "Hips", "Spine": "Spine1", "Chest": "Spine3", "Neck": "Neck", "Head": "Head", **_limbs(_CMU_LIMBS)},
    "mixamo": {"Hips": "Hips", "Spine": "Spine1", "Chest": "Spine2", "Neck": "Neck", "Head": "Head", **_limbs(_CMU_LIMBS)},
}


class RetargetError(ValueError):
    pass


def _norm(name: str) -> str:
    return name.split(":")[-1].split("|")[-1].lower()


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
    if not isinstance(data, dict) or not all(isinstance(k, str) and isinstance(v, str) for k, v in data.items()):
        raise RetargetError(f"{os.fspath(path)}: expected a JSON object of canonical joint name -> your joint name")
    unknown = sorted(set(data) - set(CANONICAL.skeleton.names))
    if unknown:
        raise RetargetError(f"{os.fspath(path)}: not canonical joint names: {', '.join(unknown)}")
    return data


def match_joint_map(skeleton: Skeleton, joint_map: dict[str, str] | None = None, source: str = "skeleton") -> tuple[str, list[int]]:
    """Find, for every canonical joint, the index of its joint in ``skeleton``.

    Tries ``joint_map`` if given, else the known maps. Returns (map name, indices).
    """
    lookup = {_norm(n): i for i, n in enumerate(skeleton.names)}
    candidates = {"user": joint_map} if joint_map is not None else JOINT_MAPS
    best_missing: list[str] | None = None
    for name, jm in candidates.items():
        idx, missing = [], []
        for canon in CANONICAL.skeleton.names:
            i = lookup.get(_norm(jm.get(canon, "")))
            (missing.append(canon) if i is None else idx.append(i))
        if not missing:
            return name, idx
        if best_missing is None or len(missing) < len(best_missing):
            best_missing = missing
    tried = "your joint map" if joint_map is not None else "the Bandai, CMU, AnimatedDrawings and Mixamo maps"
    raise RetargetError(
        f"{source}: cannot map these canonical joints to the skeleton ({tried}): {', '.join(best_missing or [])}. "
        f"Pass --joint-map MAP.json, a JSON object naming your joint for each of the {CANONICAL.num_joints} "
        f'canonical joints, e.g. {{"Hips": "pelvis", "Spine": "spine_01", ...}}; canonical joints: '
        f"{', '.join(CANONICAL.skeleton.names)}"
    )


@dataclass(frozen=True)
class Rig:
    """How one skeleton relates to the canonical skeleton (see the module docstring)."""

    skeleton: Skeleton
    mapping: tuple[int, ...]  # skeleton joint index for each canonical joint
    basis: torch.Tensor  # (4,) rotation from this skeleton's world to the canonical Y-up world
    tpose: torch.Tensor  # (J, 4) global rotations, in the canonical world, of the T-pose
    scale: float  # canonical leg length / this skeleton's leg length
    map_name: str


def _chain_length(sk: Skeleton, top: int, bottom: int) -> float:
    length, j = 0.0, bottom
    while j != top and j >= 0:
        length += float(sk.offsets[j].norm())
        j = sk.parents[j]
    return length


def detect_up_basis(gpos: torch.Tensor, hips: int, head: int) -> torch.Tensor:
    """Rotation ``(4,)`` taking the axis nearest the mean hips->head direction of ``gpos (T, J, 3)`` to +Y."""
    up = (gpos[:, head] - gpos[:, hips]).mean(0)
    axis = int(up.abs().argmax())
    v = torch.zeros(3)
    v[axis] = float(torch.sign(up[axis])) or 1.0
    return quat.between(v, torch.tensor([0.0, 1.0, 0.0]))


def make_rig(
    skeleton: Skeleton,
    sample: Motion | None = None,
    joint_map: dict[str, str] | None = None,
    spec: CanonicalSpec = CANONICAL,
    source: str = "skeleton",
) -> Rig:
    """Build the :class:`Rig` of ``skeleton``; ``sample`` (a motion on it) decides which axis is up."""
    map_name, mapping = match_joint_map(skeleton, joint_map, source)
    canon = spec.skeleton
    if skeleton.names == canon.names:
        basis = quat.identity()
    elif sample is not None:
        basis = detect_up_basis(sample.global_positions(), mapping[0], mapping[canon.index("Head")])
    else:
        basis = quat.identity()
    rest = rest_positions(skeleton.offsets.double(), skeleton.parents)
    canon_rest = rest_positions(canon.offsets.double(), canon.parents)
    of = {s: c for c, s in enumerate(mapping)}  # skeleton joint -> canonical joint
    b = basis.double()
    world = [None] * skeleton.num_joints
    for s in range(skeleton.num_joints):
        parent = world[skeleton.parents[s]] if s > 0 else b
        c = of.get(s)
        kids = [k for k in canon.children(c)] if c is not None else []
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
    return Rig(skeleton, tuple(mapping), basis.float(), tpose, leg_canon / leg_src, map_name)


def to_canonical(motion: Motion, rig: Rig, spec: CanonicalSpec = CANONICAL) -> Motion:
    """A motion on ``rig.skeleton`` -> the same motion on the canonical skeleton (same fps)."""
    if motion.skeleton.names != rig.skeleton.names:
        raise RetargetError("to_canonical: the motion's skeleton is not the rig's skeleton")
    grot, gpos = fk(motion.lrot, motion.lpos, motion.skeleton.parents)
    m = list(rig.mapping)
    b = rig.basis
    # canonical global = B * G_src * T_src^-1  (T-pose of the canonical skeleton is its rest)
    g_canon = quat.mul(quat.mul(b, grot[:, m]), quat.inv(rig.tpose[m]))
    g_canon = quat.unroll(g_canon, dim=0)
    lrot = to_local(g_canon, spec.skeleton.parents)
    lpos = spec.skeleton.offsets.expand(motion.num_frames, -1, -1).clone()
    lpos[:, 0] = quat.mul_vec(b, gpos[:, m[0]]) * rig.scale
    return Motion(spec.skeleton, lrot, lpos, motion.fps)


def from_canonical(motion: Motion, rig: Rig, spec: CanonicalSpec = CANONICAL) -> Motion:
    """A canonical motion -> the same motion on ``rig.skeleton`` (its offsets, same fps)."""
    if motion.skeleton.names != spec.skeleton.names:
        raise RetargetError("from_canonical: expected a motion on the canonical skeleton")
    sk = rig.skeleton
    t = motion.num_frames
    g_canon, _ = fk(motion.lrot, spec.skeleton.offsets.expand(t, -1, -1), spec.skeleton.parents)
    of = {s: c for c, s in enumerate(rig.mapping)}
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
    else:  # joints above the hips (e.g. Bandai's joint_Root) stay at rest; solve the hips' local offset
        pg_rot, pg_pos = fk(lrot, lpos, sk.parents)
        p = sk.parents[hips]
        lpos[:, hips] = quat.mul_vec(quat.inv(pg_rot[:, p]), hips_world - pg_pos[:, p])
    return Motion(sk, lrot, lpos, motion.fps)


def place_on_floor(motion: Motion, spec: CanonicalSpec = CANONICAL, percentile: float = 0.05) -> Motion:
    """Shift a canonical motion vertically so its feet meet y = 0 (robust to a few low frames)."""
    gpos = motion.global_positions()
    rest = rest_positions(spec.skeleton.offsets, spec.skeleton.parents)
    feet = list(spec.feet)
    clearance = gpos[:, feet, 1] - (rest[feet, 1] - rest[feet, 1].min())  # (T, 4) toe-level estimate
    lowest = clearance.min(dim=1).values
    shift = torch.quantile(lowest, percentile) - (rest[feet, 1].min() - rest[:, 1].min())
    lpos = motion.lpos.clone()
    lpos[:, 0, 1] -= shift
    return Motion(motion.skeleton, motion.lrot, lpos, motion.fps)
