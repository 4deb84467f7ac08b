"""Find the humanoid in any skeleton: which joint plays each canonical role.

The hierarchy and the rest pose decide; joint names only tell left from right when the geometry
cannot (no feet pointing forward) and pick the head out of a neck chain of look-alike joints.

* **Limbs** are pairs of sibling subtrees with the same chain of bone lengths (mirror images) that
  reach at least a quarter of the figure's size. A humanoid has two such pairs: the *legs*, whose
  common parent is the **Hips** and whose tips point away from the other pair, and the *arms*, whose
  common parent is the **Chest**. Rest pose: T or A, any up axis, any units.
* **Leg**: UpperLeg is the first joint away from the Hips (CMU's zero-length ``LHipJoint`` is an
  extra); Foot is the end of the last bone that points down (within 45°); Toes the next joint, if
  any; LowerLeg the joint nearest the middle of UpperLeg-Foot.
* **Arm**: shoulder socket, elbow and wrist are the three joints whose bones best match human arm
  proportions (upper arm a little longer than the forearm, both a third of the height, a hand
  beyond the wrist); Shoulder (the clavicle) is the joint before the socket, if any.
* **Spine**: the first joint above the Hips that is away from them, unless that is the Chest;
  **Neck** the first joint from the Chest toward the head; **Head** the joint named ``head``, else
  the last joint with a head's height above it.
* Every other joint (extra spine and neck joints, twist and roll bones, fingers, toe ends, props,
  IK targets, joints above the Hips) is an *extra*. Roles that may have no bone: Spine, Neck,
  Shoulder_L/R (no clavicle), Toes_L/R (feet that end in an End Site).
"""
from __future__ import annotations

import itertools
import math
import re
from collections import Counter
from dataclasses import dataclass

import torch

from motioncore import quat
from motioncore.kinematics import fk, rest_positions
from motioncore.skeleton import CANONICAL, Skeleton

ROLES = CANONICAL.skeleton.names
OPTIONAL_ROLES = frozenset({"Spine", "Neck", "Shoulder_L", "Shoulder_R", "Toes_L", "Toes_R"})
_AXES = ("+X", "+Y", "+Z", "-X", "-Y", "-Z")


class NotHumanoidError(ValueError):
    """No humanoid found; the message names the roles that could not be found and why."""


@dataclass(frozen=True)
class HumanoidMap:
    """For each canonical role (``ROLES`` order): the skeleton joint index or None, and how it was decided."""

    joints: tuple[int | None, ...]
    how: tuple[str, ...]
    up: str  # the up axis of the pose read, e.g. "+Y" or "+Z"
    forward: str  # the rest pose's facing axis, or "?" when the feet do not show it
    pose: str = "rest pose"  # the pose that was read: "rest pose" or "frame N"

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


def _core(name: str) -> str:
    """Lower-case name without namespace prefix, side marks, digits and punctuation."""
    n = re.split(r"[:|]", name)[-1]
    n = re.sub(r"(?i)left|right", "", n)
    n = re.sub(r"(^|[^A-Za-z])[LlRr](?=$|[^A-Za-z])", r"\1", n)
    n = re.sub(r"^[LR](?=[A-Z])", "", n)
    return re.sub(r"[^a-z]", "", n.lower())


def name_side(name: str) -> int:
    """+1 for a left-side name, -1 for right, 0 when the name does not say."""
    n = re.split(r"[:|]", name)[-1]
    low = n.lower()
    left = "left" in low or re.search(r"(^|[^a-z])l($|[^a-z])", low) or re.match(r"^L[A-Z]", n)
    right = "right" in low or re.search(r"(^|[^a-z])r($|[^a-z])", low) or re.match(r"^R[A-Z]", n)
    return 0 if bool(left) == bool(right) else (1 if left else -1)


class _Geometry:
    """Joint positions and end-site tips of one pose (default: the rest pose), subtrees and chains."""

    def __init__(self, sk: Skeleton, pos: torch.Tensor | None = None, grot: torch.Tensor | None = None):
        self.sk = sk
        self.pos = rest_positions(sk.offsets.double(), sk.parents) if pos is None else pos.double()
        self.sites = {j: (e.double() if grot is None else quat.mul_vec(grot[j].double(), e.double()))
                      for j, e in sk.end_sites.items() if 0 <= j < sk.num_joints}
        tips = [self.pos[j] + e for j, e in self.sites.items()]
        pts = torch.cat([self.pos, torch.stack(tips)]) if tips else self.pos
        self.size = float((pts.max(0).values - pts.min(0).values).max()) or 1.0  # the body's, once the hips are known
        self.eps = 0.005 * self.size  # joints closer than this coincide
        self.children = [sk.children(j) for j in range(sk.num_joints)]
        self.subtree: list[list[int]] = [[j] for j in range(sk.num_joints)]
        for j in reversed(range(1, sk.num_joints)):
            self.subtree[sk.parents[j]].extend(self.subtree[j])
        self.depth = [0.0] * sk.num_joints  # length along the bones from the root
        for j in range(1, sk.num_joints):
            self.depth[j] = self.depth[sk.parents[j]] + float(sk.offsets[j].norm())

    def extent(self, j: int) -> float:
        """Size (largest axis extent) of the subtree of ``j``, end sites included."""
        pts = torch.stack([p for k in self.subtree[j] for p in self.points(k)])
        return float((pts.max(0).values - pts.min(0).values).max())

    def points(self, j: int) -> list[torch.Tensor]:
        """The joint's position and its end-site tip, if any."""
        p = [self.pos[j]]
        if j in self.sites:
            p.append(self.pos[j] + self.sites[j])
        return p

    def path(self, top: int, bottom: int) -> list[int]:
        """Joints from ``top`` (excluded) down to ``bottom`` (included)."""
        out = []
        while bottom != top:
            out.append(bottom)
            bottom = self.sk.parents[bottom]
        return out[::-1]

    def farthest(self, origin: torch.Tensor, child: int, key=None) -> tuple[int, torch.Tensor]:
        """The joint of ``child``'s subtree owning the point that maximises ``key(point)``; by default the
        point farthest along the bones (the longest finger's tip, whatever the pose)."""
        if key is None:
            cands = [(self.depth[j] + (float(self.sites[j].norm()) if k else 0.0), j, p)
                     for j in self.subtree[child] for k, p in enumerate(self.points(j))]
        else:
            cands = [(key(p), j, p) for j in self.subtree[child] for p in self.points(j)]
        best = max(cands, key=lambda t: t[0])
        return best[1], best[2]

    def chain(self, top: int, child: int) -> tuple[list[int], torch.Tensor]:
        """Path from ``top`` to the farthest point of ``child``'s subtree, and that point."""
        end, tip = self.farthest(self.pos[top], child)
        return self.path(top, end), tip

    def bone_lengths(self, top: int, chain: list[int], tip: torch.Tensor) -> list[float]:
        pts = [self.pos[top]] + [self.pos[j] for j in chain] + [tip]
        lengths = [float((b - a).norm()) for a, b in itertools.pairwise(pts)]
        return [x for x in lengths if x > self.eps]


@dataclass
class _Pair:
    parent: int
    a: int  # child joints starting the two limbs
    b: int
    reach: float


def _limb_pairs(g: _Geometry) -> list[_Pair]:
    """Sibling subtrees whose chains start with the same bone lengths (mirror images; a hand may have fingers
    the other lacks) and reach at least a quarter of their parent's subtree."""
    pairs = []
    for h in range(g.sk.num_joints):
        kids = g.children[h]
        if len(kids) < 2:
            continue
        size = g.extent(h)
        for i, a in enumerate(kids):
            ca, ta = g.chain(h, a)
            la = g.bone_lengths(h, ca, ta)
            reach = float((ta - g.pos[h]).norm())
            if reach < 0.25 * size or len(la) < 3:
                continue
            for b in kids[i + 1:]:
                cb, tb = g.chain(h, b)
                lb = g.bone_lengths(h, cb, tb)
                n = min(len(la), len(lb))
                if n >= 3 and abs(len(la) - len(lb)) <= 2 and \
                        all(abs(x - y) <= 0.12 * max(x, y) + 2 * g.eps for x, y in zip(la[:n], lb[:n])):
                    pairs.append(_Pair(h, a, b, reach))
    return pairs


def _is_ancestor(sk: Skeleton, a: int, b: int) -> bool:
    while b >= 0:
        if b == a:
            return True
        b = sk.parents[b]
    return False


def _distinct(g: _Geometry, joints: list[int], start: torch.Tensor) -> list[int]:
    """The joints of a chain at a new position (the first of each group of coincident joints)."""
    out, last = [], start
    for j in joints:
        if float((g.pos[j] - last).norm()) > g.eps:
            out.append(j)
            last = g.pos[j]
    return out


_LEG = {"ratio": 1.0, "length": 0.5, "foot": 0.5}  # thigh/shin, (thigh+shin)/figure size, ankle-to-toe-tip/shin


def _leg(g: _Geometry, hips: int, child: int, up: torch.Tensor, side: str) -> tuple[dict, dict]:
    chain, tip = g.chain(hips, child)
    pts = _distinct(g, chain, g.pos[hips])
    if len(pts) < 3:
        raise NotHumanoidError(f"the {side} leg has {len(pts)} bones; a leg needs hip, knee and ankle")
    upper, a = pts[0], g.pos[pts[0]]
    best = None
    for k in range(1, len(pts)):
        for w in range(k + 1, len(pts)):
            e, f = g.pos[pts[k]], g.pos[pts[w]]
            l1, l2 = float((e - a).norm()), float((f - e).norm())
            cost = 4 * math.log(l1 / l2 / _LEG["ratio"]) ** 2 + math.log((l1 + l2) / g.size / _LEG["length"]) ** 2
            cost += 1 - float((f - a) @ -up) / float((f - a).norm())  # the leg points down
            l3 = float((tip - f).norm())  # a foot beyond the ankle
            cost += min(1.0, math.log(l3 / l2 / _LEG["foot"]) ** 2) if l3 > g.eps else 1.0
            if best is None or cost < best[0]:
                best = (cost, k, w)
    _, k, w = best
    toes = pts[w + 1] if w + 1 < len(pts) else None
    roles = {"UpperLeg": upper, "LowerLeg": pts[k], "Foot": pts[w], "Toes": toes}
    how = {"UpperLeg": "first leg joint away from the hips", "LowerLeg": "leg proportions (knee)",
           "Foot": "leg proportions (ankle)",
           "Toes": "joint forward of the ankle" if toes is not None else "none: the foot ends in an End Site"}
    return roles, how


_ARM = {"ratio": 1.08, "length": 0.33, "hand": 0.6}  # upper/forearm, (upper+fore)/figure size, hand/forearm
_NAMES = {"UpperArm": ("arm", "upperarm", "uparm"), "LowerArm": ("forearm", "lowerarm", "elbow"),
          "Hand": ("hand", "wrist")}


def _arm(g: _Geometry, chest: int, child: int, side: str) -> tuple[dict, dict]:
    chain, tip = g.chain(chest, child)
    pts = _distinct(g, chain, g.pos[chest])
    if len(pts) < 3:
        raise NotHumanoidError(f"the {side} arm has {len(pts)} bones; an arm needs shoulder, elbow and wrist")
    branching = [j for j in chain if len(g.children[j]) >= 2]  # the hand splits into fingers (and thumb)
    fixed = None
    if branching:
        at = chain.index(branching[-1])
        before = [i for i, j in enumerate(pts) if chain.index(j) <= at]
        fixed = before[-1] if before and before[-1] >= 2 else None
    best = None
    for i in range(len(pts)):
        for k in range(i + 1, len(pts)):
            for w in range(k + 1, len(pts)) if fixed is None else [fixed]:
                if not i < k < w:
                    continue
                s, e, h = (g.pos[pts[x]] for x in (i, k, w))
                l1, l2 = float((e - s).norm()), float((h - e).norm())
                cost = 4 * math.log(l1 / l2 / _ARM["ratio"]) ** 2
                cost += math.log((l1 + l2) / g.size / _ARM["length"]) ** 2
                cost += 2 * (1 - float((e - s) @ (h - e)) / (l1 * l2))
                l3 = float((tip - h).norm())  # a hand beyond the wrist (Bandai's hands end at the wrist)
                cost += min(1.0, math.log(l3 / l2 / _ARM["hand"]) ** 2) if l3 > g.eps else 0.0
                cost -= 0.3 * sum(_core(g.sk.names[pts[x]]) in _NAMES[r] for x, r in zip((i, k, w), _NAMES))
                if best is None or cost < best[0]:
                    best = (cost, i, k, w)
    _, i, k, w = best
    shoulder = chain[0] if chain[0] != pts[i] else None
    roles = {"Shoulder": shoulder, "UpperArm": pts[i], "LowerArm": pts[k], "Hand": pts[w]}
    how = {"Shoulder": "first joint from the chest (clavicle)" if shoulder is not None
           else "none: the upper arm hangs from the chest",
           "UpperArm": "arm proportions (shoulder socket)", "LowerArm": "arm proportions (elbow)",
           "Hand": "where the hand splits into fingers (wrist)" if fixed is not None else "arm proportions (wrist)"}
    return roles, how


def _head(g: _Geometry, chest: int, arm_children: set[int], up: torch.Tensor) -> tuple[dict, dict]:
    kids = [c for c in g.children[chest] if c not in arm_children]
    if not kids:
        raise NotHumanoidError("nothing above the chest but the arms: no neck or head")
    height = lambda p: float(p @ up)
    cands = [(g.farthest(g.pos[chest], c, key=height), c) for c in kids]
    (end, top), _ = max(cands, key=lambda t: height(t[0][1]))
    path = g.path(chest, end)
    named = [j for j in path if _core(g.sk.names[j]).endswith("head")]  # Head, head, Bip01 Head, J_Bip_C_Head
    if len(named) == 1:
        head, how = named[0], "named head"
    elif float(g.sites.get(end, torch.zeros(3)).norm()) <= g.eps and not g.children[end] and \
            float(g.sk.offsets[end].norm()) < 0.08 * g.size:
        head, how = end, "top of the neck chain, a short bone with nothing above it"  # SMPL's head
    else:
        tall = [j for j in path if height(top) - height(g.pos[j]) >= 0.05 * g.size]
        if not tall:
            raise NotHumanoidError("no head: nothing above the chest reaches a head's height")
        head, how = tall[-1], "top of the neck chain with a head's height above it"
    neck = path[0] if path[0] != head else None
    return ({"Neck": neck, "Head": head},
            {"Neck": "first joint from the chest toward the head" if neck is not None else "none: the head hangs from the chest",
             "Head": how})


def _chest_below_shoulders(g: _Geometry, hips: int, chest: int, sockets: list[int], up: torch.Tensor,
                           how: dict) -> int:
    """The Chest sits below the shoulder sockets. When the arms hang from the base of the neck (3ds Max
    Biped without "triangle neck"), the Chest is the spine joint below it, and that joint is the Neck."""
    socket = sum(float(g.pos[j] @ up) for j in sockets) / len(sockets)
    if socket - float(g.pos[chest] @ up) >= 0.02 * g.size:
        return chest
    below = [j for j in g.path(hips, chest)[:-1] if float(g.pos[chest] @ up - g.pos[j] @ up) >= 0.02 * g.size]
    if not below:
        return chest
    how["Chest"] = "spine joint below the base of the neck, where the arms hang"
    return below[-1]


def _forward(g: _Geometry, legs: list[dict], up: torch.Tensor) -> torch.Tensor | None:
    """Facing direction from the feet (ankle -> toe, or the foot's End Site), None when they do not show it."""
    dirs = []
    for leg in legs:
        ankle = leg["Foot"]
        d = g.pos[leg["Toes"]] - g.pos[ankle] if leg["Toes"] is not None else g.sites.get(ankle)
        if d is not None:
            d = d - (d @ up) * up
            if float(d.norm()) > g.eps:
                dirs.append(d / d.norm())
    if not dirs:
        return None
    f = torch.stack(dirs).sum(0)
    return f / f.norm() if float(f.norm()) > 0.5 * len(dirs) else None


def _sides(g: _Geometry, pair: _Pair, left: torch.Tensor | None, what: str) -> tuple[int, int, str]:
    """(left child, right child, how) of a limb pair: by geometry when ``left`` is known, else by names."""
    if left is not None:
        da = float((g.pos[g.subtree[pair.a]].mean(0) - g.pos[pair.parent]) @ left)
        db = float((g.pos[g.subtree[pair.b]].mean(0) - g.pos[pair.parent]) @ left)
        if abs(da - db) > g.eps:
            return (pair.a, pair.b, "left by geometry") if da > db else (pair.b, pair.a, "left by geometry")
    votes = [sum(name_side(g.sk.names[j]) for j in g.subtree[c]) for c in (pair.a, pair.b)]
    if votes[0] > 0 > votes[1] or votes[1] > 0 > votes[0]:
        return (pair.a, pair.b, "left by name") if votes[0] > 0 else (pair.b, pair.a, "left by name")
    raise NotHumanoidError(f"cannot tell the left {what} from the right: the feet do not show which way the "
                           "figure faces and the joint names do not say left/right")


def find_humanoid(skeleton: Skeleton, lrot: torch.Tensor | None = None, lpos: torch.Tensor | None = None) -> HumanoidMap:
    """The :class:`HumanoidMap` of ``skeleton``; raises :class:`NotHumanoidError` saying which roles were not
    found and why.

    The rest pose is read first. When it is not a standing T or A pose (Bandai's rest pose lays every bone
    along its joint's x axis), frames of a motion on the skeleton -- ``lrot (T, J, 4)``, ``lpos (T, J, 3)``
    -- are read instead: ten frames spread over the clip, and the mapping most of them agree on wins.
    """
    try:
        return _find(_Geometry(skeleton), "rest pose")
    except NotHumanoidError as e:
        if lrot is None or lpos is None or lrot.shape[0] == 0:
            raise
        first_error = e
    frames = sorted({int(t) for t in torch.linspace(0, lrot.shape[0] - 1, 10)})
    grot, gpos = fk(lrot[frames], lpos[frames], skeleton.parents)
    found = []
    for i, t in enumerate(frames):
        try:
            found.append(_find(_Geometry(skeleton, gpos[i], grot[i]), f"frame {t}"))
        except NotHumanoidError:
            pass
    if not found:
        raise first_error
    votes = Counter(h.joints for h in found)
    best = votes.most_common(1)[0][0]
    return next(h for h in found if h.joints == best)


def _find(g: _Geometry, pose: str) -> HumanoidMap:
    skeleton = g.sk
    pairs = _limb_pairs(g)
    if not pairs:
        raise NotHumanoidError("found no pair of mirror-image limbs (legs or arms): Hips, legs, Chest and arms not found")
    legs = arms = None
    for p in pairs:
        for q in pairs:
            if p is q or not _is_ancestor(skeleton, p.parent, q.parent):
                continue
            spine = g.pos[q.parent] - g.pos[p.parent]
            if float(spine.norm()) <= g.eps:
                continue
            spine = spine / spine.norm()
            tips = [g.chain(p.parent, c)[1] - g.pos[p.parent] for c in (p.a, p.b)]
            hanging = all(float(t @ spine) < -0.5 * float(t.norm()) for t in tips)
            if hanging and (legs is None or p.reach + q.reach > legs.reach + arms.reach):
                legs, arms = p, q
    if legs is None:
        where = ", ".join(sorted({skeleton.names[p.parent] for p in pairs}))
        if len({p.parent for p in pairs}) == 1:
            raise NotHumanoidError(f"found one pair of limbs (at {where}); a humanoid has two, legs below a spine that "
                                   "carries arms: Hips, Chest or the arm or leg roles not found")
        raise NotHumanoidError(f"found limbs at {where} but no pair hangs below a spine that carries the other "
                               "(a quadruped?): Hips, legs, Chest and arms not found")
    hips, chest = legs.parent, arms.parent
    g.size = g.extent(hips)  # the body, without joints above the hips (a root far away on the floor)
    up = g.pos[chest] - g.pos[hips]
    up_name = _axis_name(up)
    up = axis_vector(up_name)
    roles: dict[str, int | None] = {"Hips": hips, "Chest": chest}
    how = {"Hips": "common parent of the legs", "Chest": "common parent of the arms"}
    fitted = {c: _leg(g, hips, c, up, f"{skeleton.names[c]!r}") for c in (legs.a, legs.b)}  # each leg once
    fwd = _forward(g, [fitted[c][0] for c in (legs.a, legs.b)], up)
    left = None if fwd is None else torch.linalg.cross(up, axis_vector(_axis_name(fwd)))
    for pair, what in ((legs, "leg"), (arms, "arm")):
        lc, rc, side_how = _sides(g, pair, left, what)
        for c, s in ((lc, "L"), (rc, "R")):
            r, h = fitted[c] if what == "leg" else _arm(g, chest, c, "left" if s == "L" else "right")
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
    return HumanoidMap(tuple(roles[r] for r in ROLES), tuple(how[r] for r in ROLES), up_name,
                       "?" if fwd is None else _axis_name(fwd), pose)
