"""Synthetic humanoid rigs in the naming, hierarchy and rest conventions of common tools.

Each :class:`RigCase` holds a skeleton built from one realistic human rest pose, the BVH
layout that convention would be written with, and the *expected* mapping of the 21 canonical
roles (``CANONICAL.skeleton.names``) onto the rig's joints, for tests of an automatic
humanoid-skeleton mapper.

How the skeletons are made: every joint gets a global rest position in the canonical frame
(Y-up, metres, facing +Z, the character's left = +X, hips 0.95 m above the floor) from one
table of body landmarks; an A-pose turns each arm (upper arm, forearm, hand, fingers; the
clavicle stays) 45 degrees down about the forward axis at the shoulder socket. The pose is
then expressed in the rig's world axes and ``offsets = child - parent`` (the root's offset is
its global position). Rig axes:

* ``up == "Y"``: the canonical frame itself: up +Y, forward +Z, left +X.
* ``up == "Z"`` (Blender / 3ds Max convention): up +Z, forward -Y, left +X, i.e. canonical
  ``(x, y, z) -> (x, -z, y)``, a proper rotation of +90 degrees about X.

Offsets are metres whatever ``units`` says; ``layout.scale`` (metres per file unit) only says
how the BVH file of that convention would be written (``format_bvh`` divides by it).

The expected mappings follow these role rules: Hips is the lowest common ancestor of the
thighs; UpperLeg the first joint below Hips away from it; LowerLeg the knee, Foot the ankle,
Toes the ball of the foot (None without a toe joint); Chest the lowest common ancestor of the
arm chains; Spine the first joint above Hips on the way to Chest away from Hips (None if that
is Chest); Neck the first joint from Chest towards the head; Head the skull-base joint;
Shoulder the clavicle (None if the upper arm hangs from Chest); UpperArm the shoulder socket,
LowerArm the elbow, Hand the wrist. Everything else (fingers, twist/roll bones, toe ends,
IK targets, helper roots) is an extra.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import torch

from motioncore import quat
from motioncore.bvh import BvhLayout, format_bvh
from motioncore.motion import Motion
from motioncore.skeleton import CANONICAL, Skeleton

ROLES: tuple[str, ...] = CANONICAL.skeleton.names
UNIT_SCALE = {"m": 1.0, "cm": 0.01, "in": 0.0254}
_POS = ("Xposition", "Yposition", "Zposition")
LEFT, RIGHT = 1, -1
SIDES = (LEFT, RIGHT)


@dataclass(frozen=True)
class RigCase:
    """One convention's rig. ``up``: "Y" (forward +Z) or "Z" (forward -Y); left is +X in both."""

    name: str
    skeleton: Skeleton
    layout: BvhLayout
    expected: dict[str, str | None]
    up: str
    rest: str
    units: str
    note: str = field(default="", compare=False)


# ---------------------------------------------------------------------------------------------
# The rest pose: landmarks of the character's LEFT side (mirror x for the right), T-pose,
# canonical frame, metres.

_LANDMARKS = {
    "hips": (0.0, 0.95, 0.0),
    "hip": (0.09, 0.90, 0.0),  # hip socket
    "knee": (0.09, 0.49, 0.015),
    "ankle": (0.09, 0.08, -0.025),
    "ball": (0.09, 0.02, 0.11),
    "toe_tip": (0.09, 0.01, 0.18),
    "neck": (0.0, 1.44, -0.02),  # neck base
    "head": (0.0, 1.54, -0.01),  # skull base
    "head_top": (0.0, 1.72, 0.0),
    "eye": (0.032, 1.63, 0.08),
    "jaw": (0.0, 1.57, 0.03),
    "clavicle": (0.025, 1.40, 0.03),  # sterno-clavicular joint
    "shoulder": (0.18, 1.41, -0.01),  # shoulder socket
    "elbow": (0.46, 1.41, -0.01),
    "wrist": (0.71, 1.41, -0.01),
    "knuckles": (0.805, 1.41, -0.01),
    "hand_end": (0.89, 1.41, -0.01),
}
_ARM_KEYS = {"shoulder", "elbow", "wrist", "knuckles", "hand_end"}

# Finger points relative to the wrist (T-pose, palm down, thumb forward):
# 0 metacarpal base, 1 proximal (knuckle), 2 intermediate, 3 distal, 4 tip.
# For the thumb 1, 2, 3 are the CMC, MCP and IP joints (what every convention names thumb 1..3).
_FINGERS = {
    "thumb": ((0.008, -0.006, 0.010), (0.022, -0.012, 0.022), (0.050, -0.018, 0.042),
              (0.080, -0.020, 0.052), (0.105, -0.020, 0.057)),
    "index": ((0.012, 0.0, 0.012), (0.095, 0.0, 0.028), (0.140, 0.0, 0.030), (0.166, 0.0, 0.031),
              (0.188, 0.0, 0.032)),
    "middle": ((0.012, 0.0, 0.002), (0.098, 0.0, 0.007), (0.146, 0.0, 0.007), (0.176, 0.0, 0.007),
               (0.200, 0.0, 0.007)),
    "ring": ((0.012, 0.0, -0.008), (0.092, 0.0, -0.013), (0.136, 0.0, -0.015), (0.164, 0.0, -0.016),
             (0.187, 0.0, -0.017)),
    "pinky": ((0.012, 0.0, -0.016), (0.083, -0.003, -0.032), (0.118, -0.003, -0.036),
              (0.138, -0.003, -0.038), (0.157, -0.003, -0.040)),
}
FINGER_NAMES = tuple(_FINGERS)


def _vec(p: Sequence[float]) -> torch.Tensor:
    return torch.tensor(p, dtype=torch.float64)


def _mirror(p: torch.Tensor, side: int) -> torch.Tensor:
    return p * _vec((side, 1.0, 1.0))


class _Pose:
    """Global rest positions (canonical frame) of named body points for a T- or A-pose."""

    def __init__(self, rest: str):
        if rest not in ("T", "A"):
            raise ValueError(f"rest: expected 'T' or 'A', got {rest!r}")
        self.rest = rest

    def _arm(self, p: torch.Tensor) -> torch.Tensor:
        """A left-arm point of the T-pose, turned 45 degrees down about +Z at the shoulder (A-pose)."""
        if self.rest == "T":
            return p
        pivot = _vec(_LANDMARKS["shoulder"])
        a = -math.pi / 4
        d = p - pivot
        return pivot + _vec((d[0] * math.cos(a) - d[1] * math.sin(a), d[0] * math.sin(a) + d[1] * math.cos(a), d[2]))

    def at(self, key: str, side: int = LEFT) -> torch.Tensor:
        p = _vec(_LANDMARKS[key])
        return _mirror(self._arm(p) if key in _ARM_KEYS else p, side)

    def finger(self, finger: str, k: int, side: int = LEFT) -> torch.Tensor:
        return _mirror(self._arm(_vec(_LANDMARKS["wrist"]) + _vec(_FINGERS[finger][k])), side)

    def along(self, a: str, b: str, t: float, side: int = LEFT) -> torch.Tensor:
        """The point a fraction ``t`` of the way from landmark ``a`` to ``b`` (twist bones)."""
        return torch.lerp(self.at(a, side), self.at(b, side), t)

    def spine(self, t: float) -> torch.Tensor:
        """A point on the spine curve, ``t = 0`` at the hips and ``t = 1`` at the neck base."""
        p = torch.lerp(self.at("hips"), self.at("neck"), t)
        return p + _vec((0.0, 0.0, -0.025 * math.sin(math.pi * t)))


def to_rig_axes(p: torch.Tensor, up: str) -> torch.Tensor:
    """Canonical-frame vectors ``(..., 3)`` in a rig's world axes (see the module docstring)."""
    if up == "Y":
        return p
    if up == "Z":
        return torch.stack([p[..., 0], -p[..., 2], p[..., 1]], -1)
    raise ValueError(f"up: expected 'Y' or 'Z', got {up!r}")


# ---------------------------------------------------------------------------------------------
# The builder: joints by global position, names by side templates.


class _Rig:
    """Joints added by global rest position. ``tokens[side]`` fills name templates: a template
    such as ``"{S}UpLeg"`` or ``"thigh_{s}"`` gives the left and right names of one joint."""

    def __init__(self, rest: str, tokens: dict[int, dict[str, str]] | None = None):
        self.pose = _Pose(rest)
        self.tokens = tokens or {LEFT: {}, RIGHT: {}}
        self.rows: dict[str, tuple[str | None, torch.Tensor]] = {}
        self.ends: dict[str, torch.Tensor] = {}

    def n(self, template: str, side: int) -> str:
        return template.format(**self.tokens[side])

    def add(self, name: str, parent: str | None, pos: torch.Tensor, end: torch.Tensor | None = None) -> str:
        if name in self.rows:
            raise ValueError(f"duplicate joint {name!r}")
        if (parent is None) != (not self.rows) or (parent is not None and parent not in self.rows):
            raise ValueError(f"joint {name!r}: parent {parent!r} must be an existing joint (None only for the root)")
        self.rows[name] = (parent, pos)
        if end is not None:
            self.ends[name] = end
        return name

    def chain(self, parent: str, joints: Sequence[tuple[str, torch.Tensor]],
              end: torch.Tensor | None = None) -> list[str]:
        """Joints each hanging from the previous one; ``end``: an end site for the last."""
        names = []
        for i, (name, pos) in enumerate(joints):
            parent = self.add(name, parent, pos, end if i == len(joints) - 1 else None)
            names.append(parent)
        return names

    def fingers(self, hand: str, side: int, spec: dict[str, Sequence[tuple[str, int]]], tips: bool = True) -> None:
        """``spec[finger]``: (name template, finger point 0..4) from the hand outwards; a chain
        that stops before the tip (point 4) gets an end site at the tip when ``tips``."""
        for finger, joints in spec.items():
            chain = [(self.n(t, side), self.pose.finger(finger, k, side)) for t, k in joints]
            last_k = joints[-1][1]
            tip = self.pose.finger(finger, 4, side) if tips and last_k < 4 else None
            self.chain(hand, chain, end=tip)

    def drop(self, name: str) -> None:
        """Remove a joint; its children hang from its parent (their global positions stay)."""
        parent, _ = self.rows.pop(name)
        self.ends.pop(name, None)
        for child, (p, pos) in list(self.rows.items()):
            if p == name:
                self.rows[child] = (parent, pos)

    def expected(self, center: dict[str, str | None], limbs: dict[str, str | None]) -> dict[str, str | None]:
        """The 21-role mapping from the centre roles and one name template per limb role."""
        out = dict(center)
        for role, template in limbs.items():
            for side, suffix in ((LEFT, "_L"), (RIGHT, "_R")):
                out[role + suffix] = None if template is None else self.n(template, side)
        if set(out) != set(ROLES):
            raise ValueError(f"expected mapping: missing {set(ROLES) - set(out)}, unknown {set(out) - set(ROLES)}")
        return {r: out[r] for r in ROLES}

    def skeleton(self, up: str, file_order: bool = True) -> Skeleton:
        """``file_order``: joints in depth-first order, as a BVH or FBX file lists them (children in
        the order added); otherwise in the order added (SMPL's own joint order)."""
        names = tuple(self.rows)
        if file_order:
            kids: dict[str | None, list[str]] = {}
            for n, (p, _) in self.rows.items():
                kids.setdefault(p, []).append(n)
            names, stack = (), [names[0]]
            while stack:
                n = stack.pop()
                names += (n,)
                stack.extend(reversed(kids.get(n, [])))
        index = {n: i for i, n in enumerate(names)}
        parents = tuple(-1 if self.rows[n][0] is None else index[self.rows[n][0]] for n in names)
        glob = to_rig_axes(torch.stack([self.rows[n][1] for n in names]), up)
        offsets = glob - glob[[max(p, 0) for p in parents]]
        offsets[0] = glob[0]
        ends = {index[n]: (to_rig_axes(e, up) - glob[index[n]]).float() for n, e in self.ends.items()}
        return Skeleton(names, parents, offsets.float(), ends)


def _tokens(**pairs: tuple[str, str]) -> dict[int, dict[str, str]]:
    """``_tokens(S=("Left", "Right"), s=("L", "R"))`` -> per-side template fields."""
    return {side: {k: v[i] for k, v in pairs.items()} for i, side in enumerate(SIDES)}


def _thumb_and_fingers(template: str, labels: dict[str, str], ks: dict[str, Sequence[int]]) -> dict:
    """Finger spec from one template with ``{F}`` (the convention's finger label) and ``{k}``
    (the joint number, counted from 1): ``ks[finger]`` lists the finger points 0..4 to use."""
    return {f: [(template.replace("{F}", labels[f]).replace("{k}", str(i + 1)), k) for i, k in enumerate(ks[f])]
            for f in labels}


_THUMB3_FINGER3 = {f: (1, 2, 3) for f in FINGER_NAMES}  # thumb CMC..IP, fingers knuckle..distal
_THUMB4_FINGER4 = {f: (1, 2, 3, 4) for f in FINGER_NAMES}  # the same plus a tip joint


def _layout(sk: Skeleton, order: str, units: str, position: Sequence[str] | str = (),
            overrides: dict[str, str] | None = None) -> BvhLayout:
    """Rotation channels in ``order`` (``overrides``: per joint name); position channels on the
    root, on the joints named in ``position``, or on every joint when ``position == "all"``."""
    overrides = overrides or {}
    chans = []
    for i, name in enumerate(sk.names):
        rot = tuple(f"{a}rotation" for a in overrides.get(name, order))
        has_pos = i == 0 or position == "all" or name in position
        chans.append((_POS + rot) if has_pos else rot)
    return BvhLayout(tuple(chans), UNIT_SCALE[units])


# ---------------------------------------------------------------------------------------------
# Conventions. Each builder adds the joints to a _Rig and returns the expected mapping.

_ARM4 = ("clavicle", "shoulder", "elbow", "wrist")
_LEG4 = ("hip", "knee", "ankle", "ball")


def _mixamo(r: _Rig) -> dict:
    p = r.pose
    r.tokens = _tokens(S=("Left", "Right"))
    m = "mixamorig:"
    r.add(m + "Hips", None, p.at("hips"))
    r.chain(m + "Hips", [(m + "Spine", p.spine(0.2)), (m + "Spine1", p.spine(0.42)), (m + "Spine2", p.spine(0.65))])
    r.chain(m + "Spine2", [(m + "Neck", p.at("neck")), (m + "Head", p.at("head")),
                           (m + "HeadTop_End", p.at("head_top"))])
    labels = {"thumb": "Thumb", "index": "Index", "middle": "Middle", "ring": "Ring", "pinky": "Pinky"}
    for s in SIDES:
        arm = r.chain(m + "Spine2", [(r.n(m + t, s), p.at(k, s)) for t, k in
                                     zip(("{S}Shoulder", "{S}Arm", "{S}ForeArm", "{S}Hand"), _ARM4)])
        r.fingers(arm[-1], s, _thumb_and_fingers(m + "{S}Hand{F}{k}", labels, _THUMB4_FINGER4))
    for s in SIDES:
        r.chain(m + "Hips", [(r.n(m + t, s), p.at(k, s)) for t, k in
                             zip(("{S}UpLeg", "{S}Leg", "{S}Foot", "{S}ToeBase", "{S}Toe_End"), _LEG4 + ("toe_tip",))])
    return r.expected(
        {"Hips": m + "Hips", "Spine": m + "Spine", "Chest": m + "Spine2", "Neck": m + "Neck", "Head": m + "Head"},
        {"Shoulder": m + "{S}Shoulder", "UpperArm": m + "{S}Arm", "LowerArm": m + "{S}ForeArm", "Hand": m + "{S}Hand",
         "UpperLeg": m + "{S}UpLeg", "LowerLeg": m + "{S}Leg", "Foot": m + "{S}Foot", "Toes": m + "{S}ToeBase"})


def _no_toes(r: _Rig) -> dict:
    """Mixamo without toe joints: the feet end in End Sites at the ball of the foot."""
    expected = _mixamo(r)
    for s in SIDES:
        r.drop(r.n("mixamorig:{S}Toe_End", s))
        r.drop(r.n("mixamorig:{S}ToeBase", s))
        r.ends[r.n("mixamorig:{S}Foot", s)] = r.pose.at("ball", s)  # forward and down from the ankle
    return {**expected, "Toes_L": None, "Toes_R": None}


def _unreal(r: _Rig, ue5: bool) -> dict:
    """UE4 mannequin / UE5 Manny: root at the floor, IK target bones under it."""
    p = r.pose
    r.tokens = _tokens(s=("l", "r"))
    r.add("root", None, _vec((0.0, 0.0, 0.0)))
    r.add("pelvis", "root", p.at("hips"))
    spine_t = (0.1, 0.28, 0.46, 0.62, 0.76) if ue5 else (0.15, 0.4, 0.68)
    spine = r.chain("pelvis", [(f"spine_0{i + 1}", p.spine(t)) for i, t in enumerate(spine_t)])
    necks = [("neck_01", p.at("neck"))] + ([("neck_02", p.along("neck", "head", 0.5))] if ue5 else [])
    r.chain(spine[-1], necks + [("head", p.at("head"))], end=p.at("head_top"))
    twists = (1, 2) if ue5 else (1,)
    spec = {f: [(f"{f}_0{i}_{{s}}", k) for i, k in enumerate((1, 2, 3), 1)] for f in FINGER_NAMES}
    if ue5:  # metacarpals: index_metacarpal_l, then index_01_l..index_03_l
        spec.update({f: [(f"{f}_metacarpal_{{s}}", 0)] + spec[f] for f in FINGER_NAMES[1:]})
    for s in SIDES:
        _, upper, lower, hand = r.chain(spine[-1], [(r.n(t, s), p.at(k, s)) for t, k in zip(
            ("clavicle_{s}", "upperarm_{s}", "lowerarm_{s}", "hand_{s}"), _ARM4)])
        for i in twists:
            r.add(r.n(f"upperarm_twist_0{i}_{{s}}", s), upper, p.along("shoulder", "elbow", 0.25 * i, s))
            r.add(r.n(f"lowerarm_twist_0{i}_{{s}}", s), lower, p.along("elbow", "wrist", 1.0 - 0.25 * i, s))
        r.fingers(hand, s, spec)
    for s in SIDES:
        thigh, calf, _, _ = r.chain("pelvis", [(r.n(t, s), p.at(k, s)) for t, k in zip(
            ("thigh_{s}", "calf_{s}", "foot_{s}", "ball_{s}"), _LEG4)], end=p.at("toe_tip", s))
        for i in twists:
            r.add(r.n(f"thigh_twist_0{i}_{{s}}", s), thigh, p.along("hip", "knee", 0.3 * i, s))
            r.add(r.n(f"calf_twist_0{i}_{{s}}", s), calf, p.along("knee", "ankle", 0.3 * i, s))
    if ue5:
        r.add("interaction", "root", _vec((0.0, 0.0, 0.0)))
        r.add("center_of_mass", "root", p.spine(0.15))
    r.add("ik_foot_root", "root", _vec((0.0, 0.0, 0.0)))
    for s in SIDES:
        r.add(r.n("ik_foot_{s}", s), "ik_foot_root", p.at("ankle", s))
    r.add("ik_hand_root", "root", _vec((0.0, 0.0, 0.0)))
    r.add("ik_hand_gun", "ik_hand_root", p.at("wrist", RIGHT))
    for s in SIDES:
        r.add(r.n("ik_hand_{s}", s), "ik_hand_gun", p.at("wrist", s))
    return r.expected(
        {"Hips": "pelvis", "Spine": "spine_01", "Chest": spine[-1], "Neck": "neck_01", "Head": "head"},
        {"Shoulder": "clavicle_{s}", "UpperArm": "upperarm_{s}", "LowerArm": "lowerarm_{s}", "Hand": "hand_{s}",
         "UpperLeg": "thigh_{s}", "LowerLeg": "calf_{s}", "Foot": "foot_{s}", "Toes": "ball_{s}"})


def _unity(r: _Rig) -> dict:
    """Unity Humanoid (HumanBodyBones names). Chest role: UpperChest, where the clavicles hang."""
    p = r.pose
    r.tokens = _tokens(S=("Left", "Right"))
    r.add("Hips", None, p.at("hips"))
    r.chain("Hips", [("Spine", p.spine(0.15)), ("Chest", p.spine(0.4)), ("UpperChest", p.spine(0.65))])
    r.chain("UpperChest", [("Neck", p.at("neck")), ("Head", p.at("head"))], end=p.at("head_top"))
    for s in SIDES:
        r.add(r.n("{S}Eye", s), "Head", p.at("eye", s))
    r.add("Jaw", "Head", p.at("jaw"))
    labels = {"thumb": "Thumb", "index": "Index", "middle": "Middle", "ring": "Ring", "pinky": "Little"}
    phal = ("Proximal", "Intermediate", "Distal")
    for s in SIDES:
        hand = r.chain("UpperChest", [(r.n(t, s), p.at(k, s)) for t, k in zip(
            ("{S}Shoulder", "{S}UpperArm", "{S}LowerArm", "{S}Hand"), _ARM4)])[-1]
        r.fingers(hand, s, {f: [(f"{{S}}{lab}{ph}", k) for ph, k in zip(phal, (1, 2, 3))] for f, lab in labels.items()})
    for s in SIDES:
        r.chain("Hips", [(r.n(t, s), p.at(k, s)) for t, k in zip(
            ("{S}UpperLeg", "{S}LowerLeg", "{S}Foot", "{S}Toes"), _LEG4)], end=p.at("toe_tip", s))
    return r.expected(
        {"Hips": "Hips", "Spine": "Spine", "Chest": "UpperChest", "Neck": "Neck", "Head": "Head"},
        {"Shoulder": "{S}Shoulder", "UpperArm": "{S}UpperArm", "LowerArm": "{S}LowerArm", "Hand": "{S}Hand",
         "UpperLeg": "{S}UpperLeg", "LowerLeg": "{S}LowerLeg", "Foot": "{S}Foot", "Toes": "{S}Toes"})


def _no_clavicle(r: _Rig) -> dict:
    """Unity Humanoid without the optional shoulder bones: upper arms hang from UpperChest."""
    expected = _unity(r)
    for s in SIDES:
        r.drop(r.n("{S}Shoulder", s))
    return {**expected, "Shoulder_L": None, "Shoulder_R": None}


def _cmu_hips(r: _Rig) -> dict:
    """CMU as converted for MotionBuilder (cgspeed) and the Xia/Holden data: zero-length
    LHipJoint, LowerBack, Neck, LeftShoulder, LeftFingerBase and LThumb."""
    p = r.pose
    r.tokens = _tokens(S=("Left", "Right"), s=("L", "R"))
    r.add("Hips", None, p.at("hips"))
    for s in SIDES:
        helper = r.add(r.n("{s}HipJoint", s), "Hips", p.at("hips"))
        r.chain(helper, [(r.n(t, s), p.at(k, s)) for t, k in zip(
            ("{S}UpLeg", "{S}Leg", "{S}Foot", "{S}ToeBase"), _LEG4)], end=p.at("toe_tip", s))
    r.chain("Hips", [("LowerBack", p.at("hips")), ("Spine", p.spine(0.3)), ("Spine1", p.spine(0.7))])
    r.chain("Spine1", [("Neck", p.spine(0.7)), ("Neck1", p.along("neck", "head", 0.3)), ("Head", p.at("head"))],
            end=p.at("head_top"))
    for s in SIDES:
        wrist = p.at("wrist", s)
        hand = r.chain("Spine1", [(r.n("{S}Shoulder", s), p.spine(0.7)), (r.n("{S}Arm", s), p.at("shoulder", s)),
                                  (r.n("{S}ForeArm", s), p.at("elbow", s)), (r.n("{S}Hand", s), wrist)])[-1]
        r.chain(hand, [(r.n("{S}FingerBase", s), wrist), (r.n("{S}HandIndex1", s), p.finger("middle", 1, s))],
                end=p.finger("middle", 4, s))
        r.add(r.n("{s}Thumb", s), hand, wrist, end=p.finger("thumb", 4, s))
    return r.expected(
        {"Hips": "Hips", "Spine": "Spine", "Chest": "Spine1", "Neck": "Neck", "Head": "Head"},
        {"Shoulder": "{S}Shoulder", "UpperArm": "{S}Arm", "LowerArm": "{S}ForeArm", "Hand": "{S}Hand",
         "UpperLeg": "{S}UpLeg", "LowerLeg": "{S}Leg", "Foot": "{S}Foot", "Toes": "{S}ToeBase"})


def _cmu_lhipjoint(r: _Rig) -> dict:
    """The CMU variant named after the ASF bones: LeftShoulder is the UPPER ARM, LeftCollar the clavicle."""
    p = r.pose
    r.tokens = _tokens(S=("Left", "Right"), s=("L", "R"), l=("l", "r"))
    r.add("Hips", None, p.at("hips"))
    for s in SIDES:
        helper = r.add(r.n("{s}HipJoint", s), "Hips", p.at("hips"))
        r.chain(helper, [(r.n(t, s), p.at(k, s)) for t, k in zip(
            ("{S}Hip", "{S}Knee", "{S}Ankle", "{S}Toe"), _LEG4)], end=p.at("toe_tip", s))
    r.chain("Hips", [("lowerback", p.at("hips")), ("Chest", p.spine(0.3)), ("Chest2", p.spine(0.65))])
    r.chain("Chest2", [("lowerneck", p.spine(0.92)), ("Neck", p.along("neck", "head", 0.5)), ("Head", p.at("head"))],
            end=p.at("head_top"))
    for s in SIDES:
        wrist = r.chain("Chest2", [(r.n(t, s), p.at(k, s)) for t, k in zip(
            ("{S}Collar", "{S}Shoulder", "{S}Elbow", "{S}Wrist"), _ARM4)])[-1]
        r.chain(wrist, [(r.n("{l}hand", s), p.along("wrist", "knuckles", 0.3, s)),
                        (r.n("{s}Fingers", s), p.at("knuckles", s))], end=p.finger("middle", 4, s))
        r.add(r.n("{s}Thumb", s), wrist, p.finger("thumb", 1, s), end=p.finger("thumb", 4, s))
    return r.expected(
        {"Hips": "Hips", "Spine": "Chest", "Chest": "Chest2", "Neck": "lowerneck", "Head": "Head"},
        {"Shoulder": "{S}Collar", "UpperArm": "{S}Shoulder", "LowerArm": "{S}Elbow", "Hand": "{S}Wrist",
         "UpperLeg": "{S}Hip", "LowerLeg": "{S}Knee", "Foot": "{S}Ankle", "Toes": "{S}Toe"})


def _rokoko(r: _Rig) -> dict:
    """Rokoko Studio: Spine1..Spine4, LeftThigh/LeftShin/LeftToe, fingers numbered 1 (thumb) to 5."""
    p = r.pose
    r.tokens = _tokens(S=("Left", "Right"))
    r.add("Hips", None, p.at("hips"))
    r.chain("Hips", [(f"Spine{i}", p.spine(t)) for i, t in enumerate((0.15, 0.35, 0.55, 0.72), 1)])
    r.chain("Spine4", [("Neck", p.at("neck")), ("Head", p.at("head"))], end=p.at("head_top"))
    thumb = [("{S}Finger1Metacarpal", 1), ("{S}Finger1Proximal", 2), ("{S}Finger1Distal", 3), ("{S}Finger1Tip", 4)]
    spec = {"thumb": thumb}
    for i, f in enumerate(FINGER_NAMES[1:], 2):
        spec[f] = [(f"{{S}}Finger{i}{ph}", k) for ph, k in
                   zip(("Metacarpal", "Proximal", "Medial", "Distal", "Tip"), range(5))]
    for s in SIDES:
        hand = r.chain("Spine4", [(r.n(t, s), p.at(k, s)) for t, k in zip(
            ("{S}Shoulder", "{S}Arm", "{S}ForeArm", "{S}Hand"), _ARM4)])[-1]
        r.fingers(hand, s, spec)
    for s in SIDES:
        r.chain("Hips", [(r.n(t, s), p.at(k, s)) for t, k in zip(
            ("{S}Thigh", "{S}Shin", "{S}Foot", "{S}Toe", "{S}ToeTip"), _LEG4 + ("toe_tip",))])
    return r.expected(
        {"Hips": "Hips", "Spine": "Spine1", "Chest": "Spine4", "Neck": "Neck", "Head": "Head"},
        {"Shoulder": "{S}Shoulder", "UpperArm": "{S}Arm", "LowerArm": "{S}ForeArm", "Hand": "{S}Hand",
         "UpperLeg": "{S}Thigh", "LowerLeg": "{S}Shin", "Foot": "{S}Foot", "Toes": "{S}Toe"})


def _biped(r: _Rig, triangle_neck: bool = True) -> dict:
    """3ds Max Biped. Thighs hang from ``Bip01 Spine`` (Triangle Pelvis off), so Hips is
    ``Bip01 Spine``. Triangle Neck on: clavicles on the top spine link; off: on ``Bip01 Neck``.
    The names hold spaces, as in the Max scene; parse_bvh reads a name as one token."""
    p = r.pose
    r.tokens = _tokens(s=("L", "R"))
    b = "Bip01"
    r.add(b, None, p.at("hips"))
    r.add(f"{b} Footsteps", b, _vec((0.0, 0.0, 0.0)))
    r.add(f"{b} Pelvis", b, p.at("hips"))
    r.chain(f"{b} Pelvis", [(f"{b} Spine", p.spine(0.1)), (f"{b} Spine1", p.spine(0.4)), (f"{b} Spine2", p.spine(0.7))])
    r.chain(f"{b} Spine2", [(f"{b} Neck", p.at("neck")), (f"{b} Head", p.at("head")),
                            (f"{b} HeadNub", p.at("head_top"))])
    clav_parent = f"{b} Spine2" if triangle_neck else f"{b} Neck"
    spec = {f: [(f"{b} {{s}} Finger{i}{j or ''}", k) for j, k in enumerate((1, 2, 3))]  # Finger1, Finger11, Finger12
            + [(f"{b} {{s}} Finger{i}Nub", 4)] for i, f in enumerate(FINGER_NAMES)}
    for s in SIDES:
        hand = r.chain(clav_parent, [(r.n(f"{b} {{s}} {t}", s), p.at(k, s)) for t, k in zip(
            ("Clavicle", "UpperArm", "Forearm", "Hand"), _ARM4)])[-1]
        r.fingers(hand, s, spec)
    for s in SIDES:
        r.chain(f"{b} Spine", [(r.n(f"{b} {{s}} {t}", s), p.at(k, s)) for t, k in zip(
            ("Thigh", "Calf", "Foot", "Toe0", "Toe0Nub"), _LEG4 + ("toe_tip",))])
    chest = f"{b} Spine2"
    return r.expected(
        {"Hips": f"{b} Spine", "Spine": f"{b} Spine1", "Chest": chest, "Neck": f"{b} Neck", "Head": f"{b} Head"},
        {"Shoulder": b + " {s} Clavicle", "UpperArm": b + " {s} UpperArm", "LowerArm": b + " {s} Forearm",
         "Hand": b + " {s} Hand", "UpperLeg": b + " {s} Thigh", "LowerLeg": b + " {s} Calf", "Foot": b + " {s} Foot",
         "Toes": b + " {s} Toe0"})


def _rigify(r: _Rig) -> dict:
    """Blender Rigify deform bones, with in-line ``.001`` twist segments on arms and legs."""
    p = r.pose
    r.tokens = _tokens(s=("L", "R"))
    r.add("DEF-spine", None, p.at("hips"))
    spine = r.chain("DEF-spine", [(f"DEF-spine.00{i}", p.spine(t)) for i, t in enumerate((0.18, 0.42, 0.66), 1)])
    r.chain(spine[-1], [("DEF-spine.004", p.at("neck")), ("DEF-spine.005", p.along("neck", "head", 0.5)),
                        ("DEF-spine.006", p.at("head"))], end=p.at("head_top"))
    for s in SIDES:
        r.add(r.n("DEF-breast.{s}", s), "DEF-spine.003", p.spine(0.66) + _mirror(_vec((0.07, 0.0, 0.1)), s))
        r.chain("DEF-spine.003", [
            (r.n("DEF-shoulder.{s}", s), p.at("clavicle", s)), (r.n("DEF-upper_arm.{s}", s), p.at("shoulder", s)),
            (r.n("DEF-upper_arm.{s}.001", s), p.along("shoulder", "elbow", 0.5, s)),
            (r.n("DEF-forearm.{s}", s), p.at("elbow", s)),
            (r.n("DEF-forearm.{s}.001", s), p.along("elbow", "wrist", 0.5, s)),
            (r.n("DEF-hand.{s}", s), p.at("wrist", s))])
        for i, f in enumerate(FINGER_NAMES[1:], 1):
            palm = r.add(r.n(f"DEF-palm.0{i}.{{s}}", s), r.n("DEF-hand.{s}", s), p.finger(f, 0, s))
            chains = {f: [(f"DEF-f_{f}.0{j}.{{s}}", j) for j in (1, 2, 3)]}
            if f == "index":  # the thumb hangs from the index metacarpal, as in the metarig
                chains["thumb"] = [(f"DEF-thumb.0{j}.{{s}}", j) for j in (1, 2, 3)]
            r.fingers(palm, s, chains)
    for s in SIDES:
        r.add(r.n("DEF-pelvis.{s}", s), "DEF-spine", p.at("hips"),
              end=p.at("hips") + _mirror(_vec((0.1, 0.05, 0.08)), s))
        r.chain("DEF-spine", [
            (r.n("DEF-thigh.{s}", s), p.at("hip", s)), (r.n("DEF-thigh.{s}.001", s), p.along("hip", "knee", 0.5, s)),
            (r.n("DEF-shin.{s}", s), p.at("knee", s)), (r.n("DEF-shin.{s}.001", s), p.along("knee", "ankle", 0.5, s)),
            (r.n("DEF-foot.{s}", s), p.at("ankle", s)), (r.n("DEF-toe.{s}", s), p.at("ball", s))],
            end=p.at("toe_tip", s))
    return r.expected(
        {"Hips": "DEF-spine", "Spine": "DEF-spine.001", "Chest": "DEF-spine.003", "Neck": "DEF-spine.004",
         "Head": "DEF-spine.006"},
        {"Shoulder": "DEF-shoulder.{s}", "UpperArm": "DEF-upper_arm.{s}", "LowerArm": "DEF-forearm.{s}",
         "Hand": "DEF-hand.{s}", "UpperLeg": "DEF-thigh.{s}", "LowerLeg": "DEF-shin.{s}", "Foot": "DEF-foot.{s}",
         "Toes": "DEF-toe.{s}"})


# SMPL's 24 joints in their own order (parents first, sides interleaved): name, parent, position.
_SMPL_BODY = (
    ("pelvis", None, "hips"), ("left_hip", "pelvis", "hip"), ("right_hip", "pelvis", "hip"),
    ("spine1", "pelvis", 0.22), ("left_knee", "left_hip", "knee"), ("right_knee", "right_hip", "knee"),
    ("spine2", "spine1", 0.45), ("left_ankle", "left_knee", "ankle"), ("right_ankle", "right_knee", "ankle"),
    ("spine3", "spine2", 0.6), ("left_foot", "left_ankle", "ball"), ("right_foot", "right_ankle", "ball"),
    ("neck", "spine3", "neck"), ("left_collar", "spine3", "clavicle"), ("right_collar", "spine3", "clavicle"),
    ("head", "neck", "head"), ("left_shoulder", "left_collar", "shoulder"),
    ("right_shoulder", "right_collar", "shoulder"), ("left_elbow", "left_shoulder", "elbow"),
    ("right_elbow", "right_shoulder", "elbow"), ("left_wrist", "left_elbow", "wrist"),
    ("right_wrist", "right_elbow", "wrist"), ("left_hand", "left_wrist", "knuckles"),
    ("right_hand", "right_wrist", "knuckles"),
)


def _smpl(r: _Rig, smplx: bool = False) -> dict:
    """SMPL (24 joints) or SMPL-X (55: no *_hand, plus jaw, eyes and 15 finger joints a hand)."""
    p = r.pose
    r.tokens = _tokens(l=("left", "right"))
    for name, parent, where in _SMPL_BODY:
        if smplx and name.endswith("_hand"):
            continue
        side = RIGHT if name.startswith("right") else LEFT
        r.add(name, parent, p.spine(where) if isinstance(where, float) else p.at(where, side))
    if smplx:
        r.add("jaw", "head", p.at("jaw"), end=p.at("jaw") + _vec((0.0, -0.05, 0.07)))
        for s in SIDES:
            r.add(r.n("{l}_eye_smplhf", s), "head", p.at("eye", s), end=p.at("eye", s) + _vec((0.0, 0.0, 0.02)))
        for s in SIDES:  # SMPL-X order: index, middle, pinky, ring, thumb
            for f in ("index", "middle", "pinky", "ring", "thumb"):
                r.fingers(r.n("{l}_wrist", s), s, {f: [(f"{{l}}_{f}{k}", k) for k in (1, 2, 3)]})
    return r.expected(
        {"Hips": "pelvis", "Spine": "spine1", "Chest": "spine3", "Neck": "neck", "Head": "head"},
        {"Shoulder": "{l}_collar", "UpperArm": "{l}_shoulder", "LowerArm": "{l}_elbow", "Hand": "{l}_wrist",
         "UpperLeg": "{l}_hip", "LowerLeg": "{l}_knee", "Foot": "{l}_ankle", "Toes": "{l}_foot"})


def _vrm(r: _Rig) -> dict:
    """VRM 1.0 humanoid bone names used as node names (VRM 1.0 faces +Z; VRM 0.x faced -Z)."""
    p = r.pose
    r.tokens = _tokens(l=("left", "right"))
    r.add("hips", None, p.at("hips"))
    r.chain("hips", [("spine", p.spine(0.15)), ("chest", p.spine(0.4)), ("upperChest", p.spine(0.65))])
    r.chain("upperChest", [("neck", p.at("neck")), ("head", p.at("head"))], end=p.at("head_top"))
    for s in SIDES:
        r.add(r.n("{l}Eye", s), "head", p.at("eye", s))
    r.add("jaw", "head", p.at("jaw"))
    spec = {"thumb": [("{l}ThumbMetacarpal", 1), ("{l}ThumbProximal", 2), ("{l}ThumbDistal", 3)]}
    for f in FINGER_NAMES[1:]:
        label = "Little" if f == "pinky" else f.capitalize()
        spec[f] = [(f"{{l}}{label}{ph}", k) for ph, k in zip(("Proximal", "Intermediate", "Distal"), (1, 2, 3))]
    for s in SIDES:
        hand = r.chain("upperChest", [(r.n(t, s), p.at(k, s)) for t, k in zip(
            ("{l}Shoulder", "{l}UpperArm", "{l}LowerArm", "{l}Hand"), _ARM4)])[-1]
        r.fingers(hand, s, spec)
    for s in SIDES:
        r.chain("hips", [(r.n(t, s), p.at(k, s)) for t, k in zip(
            ("{l}UpperLeg", "{l}LowerLeg", "{l}Foot", "{l}Toes"), _LEG4)], end=p.at("toe_tip", s))
    return r.expected(
        {"Hips": "hips", "Spine": "spine", "Chest": "upperChest", "Neck": "neck", "Head": "head"},
        {"Shoulder": "{l}Shoulder", "UpperArm": "{l}UpperArm", "LowerArm": "{l}LowerArm", "Hand": "{l}Hand",
         "UpperLeg": "{l}UpperLeg", "LowerLeg": "{l}LowerLeg", "Foot": "{l}Foot", "Toes": "{l}Toes"})


def _vroid(r: _Rig) -> dict:
    """A VRoid Studio export: ``Root`` at the floor, J_Bip_* body, J_Adj_* eyes, J_Sec_* hair and bust chains."""
    p = r.pose
    r.tokens = _tokens(s=("L", "R"))
    r.add("Root", None, _vec((0.0, 0.0, 0.0)))
    r.add("J_Bip_C_Hips", "Root", p.at("hips"))
    r.chain("J_Bip_C_Hips", [("J_Bip_C_Spine", p.spine(0.15)), ("J_Bip_C_Chest", p.spine(0.4)),
                             ("J_Bip_C_UpperChest", p.spine(0.65))])
    r.chain("J_Bip_C_UpperChest", [("J_Bip_C_Neck", p.at("neck")), ("J_Bip_C_Head", p.at("head"))],
            end=p.at("head_top"))
    for s in SIDES:
        r.add(r.n("J_Adj_{s}_FaceEye", s), "J_Bip_C_Head", p.at("eye", s))
        bust = [p.spine(0.6) + _mirror(_vec(d), s) for d in ((0.07, 0.0, 0.08), (0.075, 0.0, 0.13))]
        r.chain("J_Bip_C_UpperChest", [(r.n("J_Sec_{s}_Bust1", s), bust[0]), (r.n("J_Sec_{s}_Bust2", s), bust[1])])
    # hair hanging down the back of the head, well below the skull base
    r.chain("J_Bip_C_Head", [("J_Sec_Hair1_01", _vec((0.0, 1.66, -0.09))), ("J_Sec_Hair2_01", _vec((0.0, 1.5, -0.12))),
                             ("J_Sec_Hair3_01", _vec((0.0, 1.34, -0.13)))], end=_vec((0.0, 1.2, -0.13)))
    labels = {"thumb": "Thumb", "index": "Index", "middle": "Middle", "ring": "Ring", "pinky": "Little"}
    for s in SIDES:
        hand = r.chain("J_Bip_C_UpperChest", [(r.n(f"J_Bip_{{s}}_{t}", s), p.at(k, s)) for t, k in zip(
            ("Shoulder", "UpperArm", "LowerArm", "Hand"), _ARM4)])[-1]
        r.fingers(hand, s, _thumb_and_fingers("J_Bip_{s}_{F}{k}", labels, _THUMB3_FINGER3))
    for s in SIDES:
        r.chain("J_Bip_C_Hips", [(r.n(f"J_Bip_{{s}}_{t}", s), p.at(k, s)) for t, k in zip(
            ("UpperLeg", "LowerLeg", "Foot", "ToeBase"), _LEG4)], end=p.at("toe_tip", s))
    return r.expected(
        {"Hips": "J_Bip_C_Hips", "Spine": "J_Bip_C_Spine", "Chest": "J_Bip_C_UpperChest", "Neck": "J_Bip_C_Neck",
         "Head": "J_Bip_C_Head"},
        {role: f"J_Bip_{{s}}_{t}" for role, t in (
            ("Shoulder", "Shoulder"), ("UpperArm", "UpperArm"), ("LowerArm", "LowerArm"), ("Hand", "Hand"),
            ("UpperLeg", "UpperLeg"), ("LowerLeg", "LowerLeg"), ("Foot", "Foot"), ("Toes", "ToeBase"))})


def _hik(r: _Rig) -> dict:
    """MotionBuilder HumanIK: Reference at the floor, roll bones as leaves, InHand metacarpals."""
    p = r.pose
    r.tokens = _tokens(S=("Left", "Right"))
    r.add("Reference", None, _vec((0.0, 0.0, 0.0)))
    r.add("Hips", "Reference", p.at("hips"))
    for s in SIDES:
        up, low, _, _ = r.chain("Hips", [(r.n(t, s), p.at(k, s)) for t, k in zip(
            ("{S}UpLeg", "{S}Leg", "{S}Foot", "{S}ToeBase"), _LEG4)], end=p.at("toe_tip", s))
        r.add(r.n("{S}UpLegRoll", s), up, p.along("hip", "knee", 0.5, s))
        r.add(r.n("{S}LegRoll", s), low, p.along("knee", "ankle", 0.5, s))
    r.chain("Hips", [(f"Spine{i or ''}", p.spine(t)) for i, t in enumerate((0.12, 0.32, 0.52, 0.7))])
    r.chain("Spine3", [("Neck", p.at("neck")), ("Neck1", p.along("neck", "head", 0.5)), ("Head", p.at("head"))],
            end=p.at("head_top"))
    labels = {"thumb": "Thumb", "index": "Index", "middle": "Middle", "ring": "Ring", "pinky": "Pinky"}
    for s in SIDES:
        _, arm, fore, hand = r.chain("Spine3", [(r.n(t, s), p.at(k, s)) for t, k in zip(
            ("{S}Shoulder", "{S}Arm", "{S}ForeArm", "{S}Hand"), _ARM4)])
        r.add(r.n("{S}ArmRoll", s), arm, p.along("shoulder", "elbow", 0.5, s))
        r.add(r.n("{S}ForeArmRoll", s), fore, p.along("elbow", "wrist", 0.5, s))
        spec = _thumb_and_fingers("{S}Hand{F}{k}", labels, _THUMB4_FINGER4)
        for f, label in labels.items():
            if f != "thumb":
                spec[f] = [(f"{{S}}InHand{label}", 0)] + spec[f]
        r.fingers(hand, s, spec)
    return r.expected(
        {"Hips": "Hips", "Spine": "Spine", "Chest": "Spine3", "Neck": "Neck", "Head": "Head"},
        {"Shoulder": "{S}Shoulder", "UpperArm": "{S}Arm", "LowerArm": "{S}ForeArm", "Hand": "{S}Hand",
         "UpperLeg": "{S}UpLeg", "LowerLeg": "{S}Leg", "Foot": "{S}Foot", "Toes": "{S}ToeBase"})


def _bandai(r: _Rig) -> dict:
    """Bandai-Namco Research Motion Dataset layout: joint_Root at the floor, then the canonical joints."""
    p = r.pose
    r.tokens = _tokens(s=("L", "R"))
    r.add("joint_Root", None, _vec((0.0, 0.0, 0.0)))
    r.add("Hips", "joint_Root", p.at("hips"))
    r.chain("Hips", [("Spine", p.spine(0.25)), ("Chest", p.spine(0.5))])
    r.chain("Chest", [("Neck", p.at("neck")), ("Head", p.at("head"))], end=p.at("head_top"))
    limbs = {"Shoulder": "Shoulder_{s}", "UpperArm": "UpperArm_{s}", "LowerArm": "LowerArm_{s}", "Hand": "Hand_{s}",
             "UpperLeg": "UpperLeg_{s}", "LowerLeg": "LowerLeg_{s}", "Foot": "Foot_{s}", "Toes": "Toes_{s}"}
    for s in SIDES:
        r.chain("Chest", [(r.n(t, s), p.at(k, s)) for t, k in zip(list(limbs.values())[:4], _ARM4)],
                end=p.at("hand_end", s))
    for s in SIDES:
        r.chain("Hips", [(r.n(t, s), p.at(k, s)) for t, k in zip(list(limbs.values())[4:], _LEG4)],
                end=p.at("toe_tip", s))
    return r.expected({k: k for k in ("Hips", "Spine", "Chest", "Neck", "Head")}, limbs)


def _animated_drawings(r: _Rig) -> dict:
    """Meta's AnimatedDrawings ``fair1_*.bvh`` structure (names, order, HandEnd and HandThumb1 joints)."""
    p = r.pose
    r.tokens = _tokens(S=("Left", "Right"))
    r.add("Hips", None, p.at("hips"))
    r.chain("Hips", [("Spine", p.spine(0.12)), ("Spine1", p.spine(0.3)), ("Spine2", p.spine(0.48)),
                     ("Spine3", p.spine(0.66))])
    r.chain("Spine3", [("Neck", p.at("neck")), ("Head", p.at("head"))], end=p.at("head_top"))
    for s in (RIGHT, LEFT):  # the file lists the right side first
        hand = r.chain("Spine3", [(r.n(t, s), p.at(k, s)) for t, k in zip(
            ("{S}Shoulder", "{S}Arm", "{S}ForeArm", "{S}Hand"), _ARM4)])[-1]
        r.add(r.n("{S}HandEnd", s), hand, p.at("knuckles", s), end=p.at("hand_end", s))
        r.add(r.n("{S}HandThumb1", s), hand, p.finger("thumb", 1, s), end=p.finger("thumb", 4, s))
    for s in (RIGHT, LEFT):
        r.chain("Hips", [(r.n(t, s), p.at(k, s)) for t, k in zip(
            ("{S}UpLeg", "{S}Leg", "{S}Foot", "{S}ToeBase"), _LEG4)], end=p.at("toe_tip", s))
    return r.expected(
        {"Hips": "Hips", "Spine": "Spine", "Chest": "Spine3", "Neck": "Neck", "Head": "Head"},
        {"Shoulder": "{S}Shoulder", "UpperArm": "{S}Arm", "LowerArm": "{S}ForeArm", "Hand": "{S}Hand",
         "UpperLeg": "{S}UpLeg", "LowerLeg": "{S}Leg", "Foot": "{S}Foot", "Toes": "{S}ToeBase"})


# ---------------------------------------------------------------------------------------------
# The table.


def _make(name: str, build: Callable[[_Rig], dict], *, up: str, rest: str, units: str, order: str,
          position: Sequence[str] | str = (), overrides: dict[str, str] | None = None, note: str = "",
          file_order: bool = True) -> RigCase:
    r = _Rig(rest)
    expected = build(r)
    sk = r.skeleton(up, file_order)
    missing = [n for n in expected.values() if n is not None and n not in sk.names]
    if missing:
        raise ValueError(f"rig {name}: expected joints {missing} are not in the skeleton")
    return RigCase(name, sk, _layout(sk, order, units, position, overrides), expected, up, rest, units, note)


# name, builder, up, rest, units, rotation order, extra BVH options
_TABLE: tuple[tuple, ...] = (
    ("mixamo", _mixamo, "Y", "T", "cm", "ZXY", {}),
    ("ue4", lambda r: _unreal(r, ue5=False), "Z", "A", "cm", "XYZ", {}),
    ("ue5", lambda r: _unreal(r, ue5=True), "Z", "A", "cm", "YZX", {}),
    ("unity", _unity, "Y", "T", "m", "ZXY", {}),
    ("cmu_hips", _cmu_hips, "Y", "T", "in", "ZYX", {}),
    ("cmu_lhipjoint", _cmu_lhipjoint, "Y", "T", "cm", "ZXY", {}),
    ("rokoko", _rokoko, "Y", "T", "m", "YXZ", {}),
    ("biped", _biped, "Z", "T", "in", "ZXY", {}),
    ("rigify", _rigify, "Z", "A", "m", "XYZ", {}),
    ("smpl", _smpl, "Y", "T", "m", "ZYX", {"file_order": False}),  # SMPL's own joint order
    ("smplx", lambda r: _smpl(r, smplx=True), "Y", "A", "m", "XZY", {"file_order": False}),
    ("vrm", _vrm, "Y", "T", "m", "ZXY", {}),
    ("vroid", _vroid, "Y", "T", "m", "YZX", {}),
    ("hik", _hik, "Y", "T", "cm", "XYZ", {"position": ("Hips",)}),  # Reference (the root) and Hips
    ("bandai", _bandai, "Y", "T", "cm", "ZXY", {"position": "all"}),
    ("animated_drawings", _animated_drawings, "Z", "T", "cm", "XYZ",
     {"overrides": {"LeftHandThumb1": "YXZ", "RightHandThumb1": "YXZ"},
      "note": "Z-up like the real fair1_*.bvh files (those use an odd unit, about 3.8 cm)"}),
    ("no_clavicle", _no_clavicle, "Y", "T", "m", "YXZ", {}),
    ("no_toes", _no_toes, "Y", "T", "cm", "XZY", {}),
)

CASES: list[RigCase] = [
    _make(name, build, up=up, rest=rest, units=units, order=order, **opts)
    for name, build, up, rest, units, order, opts in _TABLE
]

DISPUTED_CASES: list[RigCase] = [
    _make("biped_classic", lambda r: _biped(r, triangle_neck=False), up="Z", rest="T", units="in", order="ZXY",
          note="Biped with Triangle Neck off: clavicles hang from 'Bip01 Neck', so the lowest common ancestor "
               "of the arms is the neck; expected follows anatomy (Chest = Bip01 Spine2, Neck = Bip01 Neck), "
               "which the plain LCA rule does not give."),
]
"""Real variants where the stated role rules and the anatomical reading disagree (not in CASES)."""


def case(name: str) -> RigCase:
    for c in CASES + DISPUTED_CASES:
        if c.name == name:
            return c
    raise KeyError(f"no rig case {name!r}; have {', '.join(c.name for c in CASES + DISPUTED_CASES)}")


def rest_motion(skeleton: Skeleton, frames: int = 3, fps: float = 30.0) -> Motion:
    """``frames`` frames of the rest pose (identity rotations, root at its rest offset)."""
    lpos = skeleton.offsets.expand(frames, -1, -1).clone()
    return Motion(skeleton, quat.identity(frames, skeleton.num_joints), lpos, fps)


# ---------------------------------------------------------------------------------------------
# Negative examples.


def _quadruped() -> Skeleton:
    """A dog-like rig (Y-up, metres, facing +Z): horizontal spine, four legs reaching the floor, a tail."""
    r = _Rig("T", _tokens(s=("L", "R")))
    v = _vec
    r.add("Pelvis", None, v((0.0, 0.55, -0.35)))
    r.chain("Pelvis", [("Spine1", v((0.0, 0.57, -0.15))), ("Spine2", v((0.0, 0.58, 0.05))),
                       ("Chest", v((0.0, 0.57, 0.2)))])
    r.chain("Chest", [("Neck", v((0.0, 0.65, 0.32))), ("Head", v((0.0, 0.78, 0.42)))], end=v((0.0, 0.74, 0.6)))
    r.chain("Pelvis", [("Tail1", v((0.0, 0.56, -0.42))), ("Tail2", v((0.0, 0.52, -0.55))),
                       ("Tail3", v((0.0, 0.45, -0.66)))],
            end=v((0.0, 0.38, -0.75)))
    for s in SIDES:
        r.chain("Pelvis", [(r.n(t, s), _mirror(v(pos), s)) for t, pos in (
            ("{s}_Thigh", (0.1, 0.5, -0.35)), ("{s}_Shin", (0.1, 0.3, -0.3)), ("{s}_Hock", (0.1, 0.15, -0.4)),
            ("{s}_HindPaw", (0.1, 0.03, -0.37)))], end=_mirror(v((0.1, 0.0, -0.31)), s))
        r.chain("Chest", [(r.n(t, s), _mirror(v(pos), s)) for t, pos in (
            ("{s}_Scapula", (0.07, 0.6, 0.22)), ("{s}_Humerus", (0.1, 0.48, 0.25)), ("{s}_Radius", (0.1, 0.3, 0.22)),
            ("{s}_FrontPaw", (0.1, 0.05, 0.24)))], end=_mirror(v((0.1, 0.0, 0.3)), s))
    return r.skeleton("Y")


def _single_chain() -> Skeleton:
    """A rope or tentacle: Blender-style Bone, Bone.001, ... in one vertical chain."""
    r = _Rig("T")
    r.add("Bone", None, _vec((0.0, 0.0, 0.0)))
    r.chain("Bone", [(f"Bone.{i:03d}", _vec((0.0, 0.2 * i, 0.0))) for i in range(1, 9)], end=_vec((0.0, 1.8, 0.0)))
    return r.skeleton("Y")


def _hand_only() -> Skeleton:
    """A tracked left hand, OpenXR joint names: Wrist, Palm, then metacarpal..tip per finger."""
    r = _Rig("T")
    r.add("Wrist", None, r.pose.at("wrist"))
    r.add("Palm", "Wrist", r.pose.along("wrist", "knuckles", 0.5))
    thumb = [("ThumbMetacarpal", 1), ("ThumbProximal", 2), ("ThumbDistal", 3), ("ThumbTip", 4)]
    spec = {"thumb": thumb}
    for f in FINGER_NAMES[1:]:
        label = "Little" if f == "pinky" else f.capitalize()
        spec[f] = [(f"{label}{ph}", k) for ph, k in
                   zip(("Metacarpal", "Proximal", "Intermediate", "Distal", "Tip"), range(5))]
    r.fingers("Wrist", LEFT, spec)
    return r.skeleton("Y")


def _two_legs_no_arms() -> Skeleton:
    """Mixamo-style legs, spine and head, but no arms (a walker rig, a lower-body capture)."""
    r = _Rig("T", _tokens(S=("Left", "Right")))
    p = r.pose
    r.add("Hips", None, p.at("hips"))
    r.chain("Hips", [("Spine", p.spine(0.2)), ("Spine1", p.spine(0.5)), ("Neck", p.at("neck")), ("Head", p.at("head"))],
            end=p.at("head_top"))
    for s in SIDES:
        r.chain("Hips", [(r.n(t, s), p.at(k, s)) for t, k in zip(
            ("{S}UpLeg", "{S}Leg", "{S}Foot", "{S}ToeBase"), _LEG4)], end=p.at("toe_tip", s))
    return r.skeleton("Y")


NON_HUMANOID: dict[str, Skeleton] = {
    "quadruped": _quadruped(),
    "single_chain": _single_chain(),
    "hand_only": _hand_only(),
    "two_legs_no_arms": _two_legs_no_arms(),
}


def _two_roots_bvh() -> str:
    """Two Bandai-layout figures side by side, each its own ROOT, one MOTION block for both."""
    base = case("bandai")
    parts = []
    for prefix, dx in (("A_", -0.6), ("B_", 0.6)):
        sk = base.skeleton
        offsets = sk.offsets.clone()
        offsets[0, 0] += dx
        renamed = Skeleton(tuple(prefix + n for n in sk.names), sk.parents, offsets, sk.end_sites)
        text = format_bvh(rest_motion(renamed, frames=2), base.layout)
        head, motion = text.split("MOTION\n")
        parts.append((head.removeprefix("HIERARCHY\n"), motion.splitlines()))
    (head_a, mot_a), (head_b, mot_b) = parts
    rows = [f"{a} {b}" for a, b in zip(mot_a[2:], mot_b[2:])]
    return "HIERARCHY\n" + head_a + head_b + "MOTION\n" + "\n".join(mot_a[:2] + rows) + "\n"


TWO_ROOTS_BVH: str = _two_roots_bvh()
