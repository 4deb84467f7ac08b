"""Find the humanoid in any skeleton: which joint plays each canonical role.

The hierarchy and the bones' lengths decide; the pose only says which pair of limbs is the legs and
which side is left. Joint names tell left from right when the geometry cannot (no feet pointing
forward), pick the head out of a neck chain of look-alike joints, and decide the whole mapping when no
pose of the clip can (:mod:`motioncore.humanoid.names`).

* **Which pose is read.** The rest pose, when it is a standing pose (legs hanging straight from the
  hips). Otherwise (Bandai's rest pose lays every bone along its joint's x axis) frames spread over the
  whole clip, and the mapping most of them agree on wins.
* **Limbs** are pairs of sibling subtrees with the same chain of bone lengths (mirror images). A
  humanoid has two such pairs: the *legs*, whose common parent is the **Hips** and which point away
  from the other pair (however bent: standing, crouching, sitting, running, lying), and the *arms*,
  whose common parent is the **Chest** and which are at least 0.4 times as long as the legs (wherever
  they are: hanging, folded, raised, on the hips, behind the back). Four limbs that all reach the ground
  below a level spine are a quadruped's.
* **Leg**: UpperLeg is the first joint away from the Hips (CMU's zero-length ``LHipJoint`` is an
  extra); LowerLeg and Foot (knee and ankle) the pair of joints whose lengths along the bones best
  match human leg proportions with a foot beyond; Toes the next joint, if any.
* **Arm**: shoulder socket, elbow and wrist are the three joints whose lengths along the bones best
  match human arm proportions (upper arm a little longer than the forearm, both a third of the height,
  a hand beyond the wrist); Shoulder (the clavicle) is the joint before the socket, if any.
* **Left** is where the hip and shoulder sockets sit -- hands may cross the body, sockets do not --
  seen from the facing the feet show.
* **Spine**: the first joint above the Hips that is away from them, unless that is the Chest;
  **Neck** the first joint from the Chest toward the head; **Head** the joint named ``head``, else
  the last joint with a head's height above it (along the body's own up, hips to chest).
* Every other joint (extra spine and neck joints, twist and roll bones, fingers, toe ends, props,
  IK targets, joints above the Hips) is an *extra*. Roles that may have no bone: Spine, Neck,
  Shoulder_L/R (no clavicle), Toes_L/R (feet that end in an End Site).
* **Up** is decided once, by :func:`up_axis`: the world axis nearest the mean hips-to-head direction
  over the clip (over the pose read when there is no clip). The rig's basis and every preview use it.
"""
from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, replace

import torch

from motioncore.humanoid.geometry import (
    NotHumanoidError,
    _Geometry,
    _is_ancestor,
    _limb_pairs,
    _Pair,
)
from motioncore.humanoid.limb_chains import (
    _arm,
    _chest_below_shoulders,
    _forward,
    _head,
    _leg,
    _sides,
)
from motioncore.humanoid.names import name_side, roles_by_convention
from motioncore.kinematics import fk, rest_positions
from motioncore.skeleton import CANONICAL, Skeleton

__all__ = [
    "OPTIONAL_ROLES",
    "ROLES",
    "HumanoidMap",
    "NotHumanoidError",
    "axis_vector",
    "decide_up",
    "find_humanoid",
    "name_side",
    "up_axis",
]

ROLES = CANONICAL.skeleton.names
OPTIONAL_ROLES = frozenset({"Spine", "Neck", "Shoulder_L", "Shoulder_R", "Toes_L", "Toes_R"})
_AXES = ("+X", "+Y", "+Z", "-X", "-Y", "-Z")


@dataclass(frozen=True)
class HumanoidMap:
    """For each canonical role (``ROLES`` order): the skeleton joint index or None, and how it was decided."""

    joints: tuple[int | None, ...]
    how: tuple[str, ...]
    up: str  # the world's up axis, e.g. "+Y" or "+Z" (up_axis over the clip, else over the rest pose)
    forward: str  # the facing axis of the pose read, or "?" when the feet do not show it
    pose: str = "rest pose"  # what decided: "rest pose", "frame N" (one of those that agree) or "joint names"

    def joint(self, role: str) -> int | None:
        return self.joints[ROLES.index(role)]

    def names(self, skeleton: Skeleton) -> dict[str, str | None]:
        """``{role: joint name or None}``, the form a joint-map file takes."""
        return {r: None if j is None else skeleton.names[j] for r, j in zip(ROLES, self.joints)}

    def extras(self, skeleton: Skeleton) -> list[int]:
        """Joints that play no role, in skeleton order."""
        used = {j for j in self.joints if j is not None}
        return [j for j in range(skeleton.num_joints) if j not in used]


def _axis_name(v: torch.Tensor) -> str:
    i = int(v.abs().argmax())
    return ("+" if v[i] >= 0 else "-") + "XYZ"[i]


def axis_vector(name: str) -> torch.Tensor:
    """``"+Y"`` -> ``tensor([0., 1., 0.])``."""
    if name not in _AXES:
        raise ValueError(f"axis_vector: expected one of {', '.join(_AXES)}, got {name!r}")
    v = torch.zeros(3, dtype=torch.float64)
    v["XYZ".index(name[1])] = 1.0 if name[0] == "+" else -1.0
    return v


FRAMES_READ = 16  # frames spread over the clip that are read when the rest pose is not a standing pose
UP_FRAMES = 1000  # frames spread over the clip that decide the up axis


def up_axis(gpos: torch.Tensor, hips: int, head: int) -> str:
    """The world axis (``"+Y"``, ``"-Z"``, ...) nearest the mean hips -> head direction of ``gpos (T, J, 3)``.

    The one place the up axis is decided: :func:`find_humanoid` calls it on frames spread over the clip
    (on the pose read when there is no clip), and the rig's basis and the previews follow its answer."""
    if gpos.dim() != 3 or gpos.shape[-1] != 3 or gpos.shape[0] == 0:
        raise ValueError(f"up_axis: expected positions (T>0, J, 3), got {tuple(gpos.shape)}")
    if not (0 <= hips < gpos.shape[1] and 0 <= head < gpos.shape[1]):
        raise ValueError(f"up_axis: expected joint indices below {gpos.shape[1]}, got hips {hips}, head {head}")
    return _axis_name((gpos[:, head] - gpos[:, hips]).double().mean(0))


def decide_up(skeleton: Skeleton, hips: int, head: int, lrot: torch.Tensor | None = None,
              lpos: torch.Tensor | None = None, feet: tuple[int, ...] = ()) -> str:
    """:func:`up_axis` of a skeleton whose Hips and Head (and ``feet``) are known: over at most
    :data:`UP_FRAMES` frames spread over the clip ``lrot (T, J, 4)``, ``lpos (T, J, 3)``, else over the rest
    pose when it stands (head above the hips along an axis, the feet below); else ``"+Y"``, the default."""
    if lrot is not None and lpos is not None and lrot.shape[0] > 0:
        return up_axis(clip_positions(skeleton, lrot, lpos)[2], hips, head)
    pos = rest_positions(skeleton.offsets.double(), skeleton.parents)
    up = pos[head] - pos[hips]
    up = up / up.norm()
    down = [pos[f] - pos[hips] for f in feet]
    if float(up.abs().max()) < 0.9 or any(float(d @ -up) < 0.8 * float(d.norm()) for d in down):
        return "+Y"  # a rest pose that shows no up (Bandai's)
    return up_axis(pos[None], hips, head)


def clip_positions(skeleton: Skeleton, lrot: torch.Tensor, lpos: torch.Tensor, most: int = UP_FRAMES
                   ) -> tuple[list[int], torch.Tensor, torch.Tensor]:
    """At most ``most`` frames spread evenly over a clip ``lrot (T, J, 4)``, ``lpos (T, J, 3)``: their
    indices and global rotations ``(N, J, 4)`` and positions ``(N, J, 3)``."""
    j = skeleton.num_joints
    if lrot.dim() != 3 or tuple(lrot.shape[1:]) != (j, 4) or lpos.dim() != 3 or tuple(lpos.shape[1:]) != (j, 3) \
            or lrot.shape[0] != lpos.shape[0]:
        raise ValueError(f"expected lrot (T, {j}, 4) and lpos (T, {j}, 3), got {tuple(lrot.shape)} and "
                         f"{tuple(lpos.shape)}")
    frames = sorted({int(t) for t in torch.linspace(0, lrot.shape[0] - 1, min(lrot.shape[0], most))})
    grot, gpos = fk(lrot[frames], lpos[frames], skeleton.parents)
    return frames, grot, gpos


def find_humanoid(skeleton: Skeleton, lrot: torch.Tensor | None = None, lpos: torch.Tensor | None = None) -> HumanoidMap:
    """The :class:`HumanoidMap` of ``skeleton``; raises :class:`NotHumanoidError` saying which roles were not
    found and why.

    The rest pose decides when it is a standing pose. Otherwise (Bandai's rest pose lays every bone along
    its joint's x axis) :data:`FRAMES_READ` frames spread over a motion on the skeleton -- ``lrot (T, J, 4)``,
    ``lpos (T, J, 3)`` -- are read, and the mapping most of them agree on wins; where no frame shows a
    humanoid or they disagree, joint names that match a known convention exactly decide. The up axis is
    :func:`up_axis` over the clip (over the pose read when there is no clip).
    """
    has_clip = lrot is not None and lpos is not None and lrot.shape[0] > 0
    clip = clip_positions(skeleton, lrot, lpos) if has_clip else None
    rest_error = None
    try:
        found, standing = _find(_Geometry(skeleton), "rest pose")
    except NotHumanoidError as e:
        found, standing, rest_error = None, False, e
    if found is None or (has_clip and not standing):
        if has_clip:
            found = _from_frames(skeleton, *clip)
        else:
            found = _by_names(skeleton, f"no pose to read: {rest_error}")
            if found is None:
                raise rest_error
    hips, head = found.joint("Hips"), found.joint("Head")
    feet = (found.joint("Foot_L"), found.joint("Foot_R"))
    return replace(found, up=up_axis(clip[2], hips, head) if has_clip else decide_up(skeleton, hips, head, feet=feet))


def _from_frames(skeleton: Skeleton, frames: list[int], grot: torch.Tensor, gpos: torch.Tensor) -> HumanoidMap:
    """The mapping most of :data:`FRAMES_READ` frames spread over the clip agree on."""
    pick = sorted({int(i) for i in torch.linspace(0, len(frames) - 1, min(len(frames), FRAMES_READ))})
    found, errors = [], Counter()
    for i in pick:
        try:
            found.append(_find(_Geometry(skeleton, gpos[i], grot[i]), f"frame {frames[i]}")[0])
        except NotHumanoidError as e:
            errors[str(e)] += 1
    votes = Counter(h.joints for h in found)
    if found:
        best, n = votes.most_common(1)[0]
        if 2 * n > len(found):
            return next(h for h in found if h.joints == best)
        why = (f"the {len(pick)} frames read disagree ({len(votes)} different mappings, the commonest in {n})"
               f": {_disputed(found, best)} ambiguous")
    else:
        error, n = errors.most_common(1)[0]
        why = error + (f" (in {n} of the {len(pick)} frames read; the others: {errors.most_common(2)[-1][0]})"
                       if n < len(pick) else f" (in all {len(pick)} frames read, spread over the clip)")
    named = _by_names(skeleton, why)
    if named is not None:
        return named
    raise NotHumanoidError(why)


def _disputed(found: list[HumanoidMap], best: tuple) -> str:
    """The roles on which the frames' mappings differ from the commonest one."""
    roles = [r for i, r in enumerate(ROLES) if any(h.joints[i] != best[i] for h in found)]
    return ", ".join(roles)


def _by_names(skeleton: Skeleton, why: str) -> HumanoidMap | None:
    """The mapping the joint names give when they match a known convention exactly (else None)."""
    named = roles_by_convention(skeleton)
    if named is None:
        return None
    convention, roles = named
    how = f"named as in the {convention} convention (the geometry could not decide: {why})"
    return HumanoidMap(tuple(roles[r] for r in ROLES), tuple(how for _ in ROLES), "?", "?", "joint names")


def _arrangement(g: _Geometry, pairs: list[_Pair]) -> tuple[_Pair, _Pair]:
    """(legs, arms): the pair of limb pairs of a humanoid, or :class:`NotHumanoidError` saying why not."""
    sk = g.sk
    best, quadruped, seen = None, None, None
    for p in pairs:
        for q in pairs:
            if p.parent == q.parent or not _is_ancestor(sk, p.parent, q.parent) or q.length < 0.4 * p.length:
                continue
            spine = g.pos[q.parent] - g.pos[p.parent]
            if float(spine.norm()) <= g.eps:
                continue
            spine = spine / spine.norm()
            seen = seen or (p, q)
            limbs = [t - g.pos[p.parent] for t in p.tips] + [t - g.pos[q.parent] for t in q.tips]
            down = torch.stack([v / v.norm() for v in limbs]).sum(0)
            down = down / down.norm()
            if all(float(v @ down) > 0.8 * float(v.norm()) for v in limbs) and abs(float(spine @ down)) < 0.5:
                quadruped = quadruped or (p, q)  # four limbs reach the ground below a level spine
                continue
            if all(float(v @ spine) < 0 for v in limbs[:2]) and \
                    (best is None or p.length + q.length > best[0].length + best[1].length):
                best = (p, q)  # the legs point away from the arms, however bent
    if best is not None:
        return best
    name = lambda j: sk.names[j]
    if quadruped is not None:
        p, q = quadruped
        raise NotHumanoidError(f"the four limbs at {name(p.parent)} and {name(q.parent)} all reach the ground below "
                               "a level spine (a quadruped?): Hips, legs, Chest and arms not found")
    where = ", ".join(sorted({name(p.parent) for p in pairs}))
    if seen is not None:
        p, q = seen
        raise NotHumanoidError(f"cannot tell the legs from the arms: the limbs at {name(p.parent)} point toward "
                               f"those at {name(q.parent)}, not away from them, in the {g.pose}: Hips and legs, "
                               "Chest and arms not found")
    if len({p.parent for p in pairs}) == 1:
        raise NotHumanoidError(f"found one pair of limbs (at {where}); a humanoid has two, legs below a spine that "
                               "carries arms: Hips, Chest or the arm or leg roles not found")
    raise NotHumanoidError(f"found limbs at {where} but no pair carries another as long along a spine: Hips, legs, "
                           "Chest and arms not found")


def _find(g: _Geometry, pose: str) -> tuple[HumanoidMap, bool]:
    """The mapping one pose shows, and whether that pose is a standing one (legs hanging straight)."""
    skeleton = g.sk
    g.pose = pose
    pairs = _limb_pairs(g)
    if not pairs:
        raise NotHumanoidError("found no pair of mirror-image limbs (legs or arms): Hips, legs, Chest and arms not found")
    legs, arms = _arrangement(g, pairs)
    hips, chest = legs.parent, arms.parent
    g.size = 1.5 * legs.length  # a figure's height, about 1.5 times hips-to-toe-tip along the bones
    up = g.pos[chest] - g.pos[hips]
    up = up / up.norm()  # the body's own up: a leaning, sitting or lying figure reads like a standing one
    roles: dict[str, int | None] = {"Hips": hips, "Chest": chest}
    how = {"Hips": "common parent of the legs", "Chest": "common parent of the arms"}
    fitted = {c: _leg(g, hips, c, f"{skeleton.names[c]!r}") for c in (legs.a, legs.b)}  # each limb once
    fitted.update({c: _arm(g, chest, c, f"{skeleton.names[c]!r}") for c in (arms.a, arms.b)})
    fwd = _forward(g, [fitted[c][0] for c in (legs.a, legs.b)], up)
    left = None if fwd is None else torch.linalg.cross(up, fwd)
    for pair, what, socket in ((legs, "leg", "UpperLeg"), (arms, "arm", "UpperArm")):
        lc, rc, side_how = _sides(g, pair.parent, (pair.a, pair.b),
                                  (fitted[pair.a][0][socket], fitted[pair.b][0][socket]), left, what)
        for c, s in ((lc, "L"), (rc, "R")):
            r, h = fitted[c]
            for k, v in r.items():
                roles[f"{k}_{s}"] = v
                how[f"{k}_{s}"] = f"{h[k]}; {side_how}"
    chest = _chest_below_shoulders(g, hips, chest, [roles["UpperArm_L"], roles["UpperArm_R"]], up, how)
    roles["Chest"] = chest
    spine_path = g.path(hips, chest)[:-1]
    spine = next((j for j in spine_path if float((g.pos[j] - g.pos[hips]).norm()) > g.eps), None)
    roles["Spine"] = spine
    how["Spine"] = "first joint above the hips" if spine is not None else "none: the chest sits on the hips"
    h_roles, h_how = _head(g, chest, {arms.a, arms.b}, up)
    roles.update(h_roles)
    how.update(h_how)
    standing = all(float((t - g.pos[hips]) @ -up) > 0.9 * float((t - g.pos[hips]).norm()) for t in legs.tips)
    return HumanoidMap(tuple(roles[r] for r in ROLES), tuple(how[r] for r in ROLES), _axis_name(up),
                       "?" if fwd is None else _axis_name(fwd), pose), standing
