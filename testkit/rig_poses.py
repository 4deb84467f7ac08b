"""The rigs of testkit/rig_corpus.py animated in poses that do not show a standing figure.

:func:`posed_motion` gives a clip of one :class:`~testkit.rig_corpus.RigCase` holding one of
:data:`POSES` for the whole clip (with a slow turn and a little sway, so no two frames are the
same). ``rest="file"`` keeps the case's standing rest pose; ``rest="bones_x"`` rewrites the rest
pose the way Bandai's files do -- every joint's first bone along its own +X, so the rest pose is a
figure lying along X -- and moves the rotations so the animated pose is the same; the mapping
must then read the pose from the frames.

A pose is a table of *global* rotations (canonical frame: Y up, +Z forward, left +X) of body
roles relative to the T-pose; a joint without an entry turns with its nearest ancestor that has
one (twist bones with their limb, fingers with the hand). A-pose rigs get their arms lifted to the
T-pose first, so the same table gives the same pose in every convention.
"""
from __future__ import annotations

import math

import torch

from motioncore import quat
from motioncore.kinematics import fk, rest_positions, to_local
from motioncore.motion import Motion
from motioncore.skeleton import Skeleton
from testkit.rig_corpus import RigCase, to_rig_axes

_X, _Y, _Z = (torch.tensor(v, dtype=torch.float64) for v in ((1.0, 0, 0), (0, 1.0, 0), (0, 0, 1.0)))


def _v(*xyz: float) -> torch.Tensor:
    v = torch.tensor(xyz, dtype=torch.float64)
    return v / v.norm()


def _aim(rest: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """Global rotation turning a bone that points along ``rest`` to ``target`` (the shortest turn)."""
    return quat.between(rest, target)


def _tilt(deg: float) -> torch.Tensor:
    """Lean the upper body forward (+Y toward +Z) by ``deg`` degrees."""
    return quat.from_axis_angle(_X, torch.tensor(math.radians(deg), dtype=torch.float64))


def _arms(upper: tuple, fore: tuple, side: str, lean: torch.Tensor | None = None) -> dict:
    """Left-arm directions (mirrored in x for the right arm) -> global rotations of UpperArm and LowerArm."""
    m = 1.0 if side == "L" else -1.0
    out = (_X if side == "L" else -_X)
    u = _v(m * upper[0], upper[1], upper[2])
    f = _v(m * fore[0], fore[1], fore[2])
    rot = {f"UpperArm_{side}": _aim(out, u), f"LowerArm_{side}": _aim(out, f)}
    if lean is not None:
        rot = {k: quat.mul(lean, q) for k, q in rot.items()}
    rot[f"Hand_{side}"] = rot[f"LowerArm_{side}"]
    return rot


def _legs(thigh: tuple, shin: tuple, side: str, foot: torch.Tensor | None = None) -> dict:
    m = 1.0 if side == "L" else -1.0
    rot = {f"UpperLeg_{side}": _aim(-_Y, _v(m * thigh[0], thigh[1], thigh[2])),
           f"LowerLeg_{side}": _aim(-_Y, _v(m * shin[0], shin[1], shin[2]))}
    rot[f"Foot_{side}"] = quat.identity(dtype=torch.float64) if foot is None else foot
    return rot


def _both(fn, left: tuple, right: tuple | None = None, **kw) -> dict:
    return {**fn(*left, "L", **kw), **fn(*(right or left), "R", **kw)}


def _pose_table() -> dict[str, tuple[dict, float, torch.Tensor | None]]:
    """name -> (global role rotations, hips height in metres, whole-body rotation or None)."""
    lean15, lean40 = _tilt(15), _tilt(40)
    run_legs = {**_legs((0.0, -0.45, 0.9), (0.0, -0.95, -0.3), "L"), **_legs((0.0, -0.9, -0.45), (0.0, -0.45, -0.9), "R")}
    return {
        # both hands at chest height, about 10 cm from the midline, for the whole clip
        "arms_folded": (_both(_arms, ((0.12, -0.9, 0.42), (-0.9, 0.25, 0.35))), 0.95, None),
        "hands_on_hips": (_both(_arms, ((0.55, -0.8, -0.25), (-0.35, -0.75, 0.35))), 0.95, None),
        "arms_overhead": (_both(_arms, ((0.25, 0.97, 0.0), (-0.05, 1.0, 0.05))), 0.95, None),
        "hands_behind_back": (_both(_arms, ((0.15, -0.9, -0.4), (-0.75, -0.25, -0.6))), 0.95, None),
        "deep_crouch": ({"Spine": lean40, **_both(_arms, ((0.1, -0.7, 0.7), (0.0, -0.8, 0.6)), lean=lean40),
                         **_both(_legs, ((0.12, 0.25, 0.96), (0.0, -0.92, -0.4)))}, 0.42, None),
        "sitting": ({**_both(_arms, ((0.1, -0.95, 0.25), (0.0, -0.3, 0.95))),
                     **_both(_legs, ((0.05, 0.0, 1.0), (0.0, -1.0, 0.0)))}, 0.52, None),
        "run_one_hand_high": ({"Spine": lean15, **_arms((0.1, -0.7, -0.7), (0.0, 0.2, 1.0), "L", lean=lean15),
                               **_arms((0.35, 0.9, 0.25), (0.1, 1.0, 0.0), "R", lean=lean15), **run_legs}, 0.9, None),
        # on the back, face up, head toward -Z
        "lying_down": (_both(_arms, ((0.3, -0.95, 0.0), (0.2, -1.0, 0.1))),
                       0.12, quat.from_axis_angle(_X, torch.tensor(-math.pi / 2, dtype=torch.float64))),
    }


POSES: tuple[str, ...] = tuple(_pose_table())
RESTS = ("file", "bones_x")


def _roles_of(c: RigCase) -> list[str | None]:
    """For each joint of the rig, the role it plays or None."""
    by_name = {n: r for r, n in c.expected.items() if n is not None}
    return [by_name.get(n) for n in c.skeleton.names]


def _canonical_rest(c: RigCase) -> torch.Tensor:
    """Rest positions (J, 3) in the canonical frame, arms of an A-pose lifted to the T-pose."""
    sk = c.skeleton
    pos = rest_positions(sk.offsets.double(), sk.parents)
    if c.up == "Z":  # rig (x, y, z) = canonical (x, -z, y)
        pos = torch.stack([pos[:, 0], pos[:, 2], -pos[:, 1]], -1)
    if c.rest == "A":
        for side, m in (("L", 1.0), ("R", -1.0)):
            s = sk.index(c.expected[f"UpperArm_{side}"])
            lift = quat.from_axis_angle(_Z, torch.tensor(m * math.pi / 4, dtype=torch.float64))
            below = [j for j in range(sk.num_joints) if _under(sk, s, j)]
            pos[below] = pos[s] + quat.mul_vec(lift, pos[below] - pos[s])
    return pos


def _under(sk: Skeleton, a: int, j: int) -> bool:
    while j >= 0:
        if j == a:
            return True
        j = sk.parents[j]
    return False


def _bones_x(sk: Skeleton) -> tuple[Skeleton, torch.Tensor]:
    """Bandai's rest convention: each joint's first child's bone along +X. Returns the new skeleton
    and each joint's rest frame ``(J, 4)`` (old rest direction = frame * new one)."""
    frames = quat.identity(sk.num_joints, dtype=torch.float64)
    for j in range(sk.num_joints):
        kids = sk.children(j)
        d = sk.offsets[kids[0]].double() if kids else sk.end_sites.get(j, torch.zeros(3)).double()
        if float(d.norm()) > 1e-6:
            frames[j] = quat.between(_X, d / d.norm())
    offsets = sk.offsets.double().clone()
    for j in range(1, sk.num_joints):
        offsets[j] = quat.mul_vec(quat.inv(frames[sk.parents[j]]), offsets[j])
    ends = {j: quat.mul_vec(quat.inv(frames[j]), e.double()).float() for j, e in sk.end_sites.items()}
    return Skeleton(sk.names, sk.parents, offsets.float(), ends), frames


def posed_motion(c: RigCase, pose: str, rest: str = "file", frames: int = 24, fps: float = 30.0) -> Motion:
    """A ``frames``-frame clip of case ``c`` holding ``pose`` (see the module docstring)."""
    if pose not in POSES:
        raise ValueError(f"pose: expected one of {', '.join(POSES)}, got {pose!r}")
    if rest not in RESTS:
        raise ValueError(f"rest: expected one of {', '.join(RESTS)}, got {rest!r}")
    table, hips_height, body = _pose_table()[pose]
    sk = c.skeleton
    roles = _roles_of(c)
    canon = _canonical_rest(c)
    # global rotation of each joint: its own role's entry, else its nearest ancestor's
    g = quat.identity(sk.num_joints, dtype=torch.float64)
    for j in range(sk.num_joints):
        if roles[j] in table:
            g[j] = table[roles[j]]
        elif j > 0:
            g[j] = g[sk.parents[j]]
    hips = sk.index(c.expected["Hips"])
    t = torch.arange(frames, dtype=torch.float64)
    yaw = 0.35 * torch.sin(2 * math.pi * t / frames)  # a slow turn back and forth
    sway = 0.04 * torch.sin(4 * math.pi * t / frames)
    turn = quat.from_axis_angle(_Y.expand(frames, 3), yaw)
    whole = turn if body is None else quat.mul(turn, body.expand(frames, 4))
    grot = quat.mul(whole[:, None], g.expand(frames, -1, -1))  # (T, J, 4), canonical frame, from the T-pose
    if roles[0] is None:  # a helper root (at the floor, or a reference) stays as it is; the body moves
        grot[:, 0] = quat.identity(dtype=torch.float64)
    # positions: bones of the canonical T-pose rest turned by the parent's global rotation
    pos = torch.zeros(frames, sk.num_joints, 3, dtype=torch.float64)
    pos[:, 0] = canon[0]
    for j in range(1, sk.num_joints):
        p = sk.parents[j]
        pos[:, j] = pos[:, p] + quat.mul_vec(grot[:, p], (canon[j] - canon[p]).expand(frames, 3))
    shift = torch.stack([sway, hips_height - pos[:, hips, 1], 0.3 * t / frames], -1)
    body_joints = [j for j in range(sk.num_joints) if _under(sk, hips, j)]  # not a helper root or IK targets
    pos[:, body_joints] += shift[:, None]
    # the A-pose's arms are the T-pose's turned down: the rotation from the file's rest is one more turn
    if c.rest == "A":
        for side, m in (("L", 1.0), ("R", -1.0)):
            drop = quat.from_axis_angle(_Z, torch.tensor(-m * math.pi / 4, dtype=torch.float64))
            s = sk.index(c.expected[f"UpperArm_{side}"])
            under = [j for j in range(sk.num_joints) if _under(sk, s, j)]
            grot[:, under] = quat.mul(grot[:, under], quat.inv(drop))
    if c.up == "Z":  # canonical -> rig axes: +90 degrees about X
        to_rig = quat.from_axis_angle(_X, torch.tensor(math.pi / 2, dtype=torch.float64))
        grot = quat.mul(quat.mul(to_rig, grot), quat.inv(to_rig))
        pos = to_rig_axes(pos, "Z")
    skel = sk
    if rest == "bones_x":
        skel, rest_frames = _bones_x(sk)
        grot = quat.mul(grot, rest_frames)
    lpos = skel.offsets.double().expand(frames, -1, -1).clone()
    lpos[:, 0] = pos[:, 0]
    if hips != 0:
        lpos[:, hips] = quat.mul_vec(quat.inv(grot[:, sk.parents[hips]]), pos[:, hips] - pos[:, sk.parents[hips]])
    lrot = to_local(grot, sk.parents)
    motion = Motion(skel, lrot.float(), lpos.float(), fps)
    _, check = fk(lrot, lpos, sk.parents)
    if float((check - pos).abs().max()) > 1e-6:
        raise AssertionError(f"posed_motion({c.name}, {pose}, {rest}): positions do not follow the rotations")
    return motion
