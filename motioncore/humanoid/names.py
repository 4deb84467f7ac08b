"""What joint names say: left or right, and the roles of a known naming convention.

Names only decide where the geometry cannot: which side is left when the feet do not show the
facing, which joint of a neck chain is the head, and -- when no pose of the clip shows a
humanoid the geometry can read -- the whole mapping, if every limb joint carries exactly the
name a known convention gives it (:func:`roles_by_convention`).
"""
from __future__ import annotations

import itertools
import re

from motioncore.skeleton import Skeleton


def core(name: str) -> str:
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


_LIMB_ROLES = ("Shoulder", "UpperArm", "LowerArm", "Hand", "UpperLeg", "LowerLeg", "Foot", "Toes")
# convention -> (head name, limb name templates in _LIMB_ROLES order, {s} the side word, then its two spellings)
CONVENTIONS: dict[str, tuple[str, tuple[str, ...], tuple[str, str]]] = {
    "Bandai / canonical": ("Head", ("Shoulder_{s}", "UpperArm_{s}", "LowerArm_{s}", "Hand_{s}", "UpperLeg_{s}",
                                    "LowerLeg_{s}", "Foot_{s}", "Toes_{s}"), ("L", "R")),
    "Mixamo / HumanIK / CMU": ("Head", ("{s}Shoulder", "{s}Arm", "{s}ForeArm", "{s}Hand", "{s}UpLeg", "{s}Leg",
                                        "{s}Foot", "{s}ToeBase"), ("Left", "Right")),
    "Unity / VRM": ("Head", ("{s}Shoulder", "{s}UpperArm", "{s}LowerArm", "{s}Hand", "{s}UpperLeg", "{s}LowerLeg",
                             "{s}Foot", "{s}Toes"), ("Left", "Right")),
    "Unreal": ("head", ("clavicle_{s}", "upperarm_{s}", "lowerarm_{s}", "hand_{s}", "thigh_{s}", "calf_{s}",
                        "foot_{s}", "ball_{s}"), ("l", "r")),
    "SMPL": ("head", ("{s}_collar", "{s}_shoulder", "{s}_elbow", "{s}_wrist", "{s}_hip", "{s}_knee", "{s}_ankle",
                      "{s}_foot"), ("left", "right")),
    "3ds Max Biped": ("Bip01 Head", ("Bip01 {s} Clavicle", "Bip01 {s} UpperArm", "Bip01 {s} Forearm",
                                     "Bip01 {s} Hand", "Bip01 {s} Thigh", "Bip01 {s} Calf", "Bip01 {s} Foot",
                                     "Bip01 {s} Toe0"), ("L", "R")),
    "VRoid": ("J_Bip_C_Head", ("J_Bip_{s}_Shoulder", "J_Bip_{s}_UpperArm", "J_Bip_{s}_LowerArm", "J_Bip_{s}_Hand",
                               "J_Bip_{s}_UpperLeg", "J_Bip_{s}_LowerLeg", "J_Bip_{s}_Foot", "J_Bip_{s}_ToeBase"),
              ("L", "R")),
    "Rokoko": ("Head", ("{s}Shoulder", "{s}Arm", "{s}ForeArm", "{s}Hand", "{s}Thigh", "{s}Shin", "{s}Foot",
                        "{s}Toe"), ("Left", "Right")),
    "CMU (collar)": ("Head", ("{s}Collar", "{s}Shoulder", "{s}Elbow", "{s}Wrist", "{s}Hip", "{s}Knee", "{s}Ankle",
                              "{s}Toe"), ("Left", "Right")),
    "Rigify": ("DEF-spine.006", ("DEF-shoulder.{s}", "DEF-upper_arm.{s}", "DEF-forearm.{s}", "DEF-hand.{s}",
                                 "DEF-thigh.{s}", "DEF-shin.{s}", "DEF-foot.{s}", "DEF-toe.{s}"), ("L", "R")),
}
_OPTIONAL = {"Shoulder", "Toes"}


def _plain(name: str) -> str:
    return re.split(r"[:|]", name)[-1].lower()  # "mixamorig:LeftArm" -> "leftarm"


def _ancestors(sk: Skeleton, j: int) -> list[int]:
    out = []
    while j >= 0:
        out.append(j)
        j = sk.parents[j]
    return out


def _lca(sk: Skeleton, a: int, b: int) -> int:
    anc = set(_ancestors(sk, b))
    return next(j for j in _ancestors(sk, a) if j in anc)


def roles_by_convention(sk: Skeleton) -> tuple[str, dict[str, int | None]] | None:
    """``(convention, {role: joint index or None})`` when every limb joint of one known convention is
    there under exactly its name (case and a namespace prefix aside) and the hierarchy agrees; else None.

    Limbs and the head come from the names; Hips, Spine, Chest and Neck from the hierarchy: Hips the
    common ancestor of the thighs, Chest that of the arms, Spine and Neck the first joints from them."""
    index: dict[str, list[int]] = {}
    for i, n in enumerate(sk.names):
        index.setdefault(_plain(n), []).append(i)
    for convention, (head_name, templates, sides) in CONVENTIONS.items():
        roles: dict[str, int | None] = {}
        ok = True
        for role, template in zip(_LIMB_ROLES, templates):
            for word, suffix in zip(sides, ("_L", "_R")):
                hits = index.get(template.format(s=word).lower(), [])
                if len(hits) > 1 or (not hits and role not in _OPTIONAL):
                    ok = False
                roles[role + suffix] = hits[0] if len(hits) == 1 else None
        heads = index.get(head_name.lower(), [])
        if not ok or len(heads) != 1:
            continue
        if (roles["Shoulder_L"] is None) != (roles["Shoulder_R"] is None):
            continue
        if not _chains_agree(sk, roles):
            continue
        hips = _lca(sk, roles["UpperLeg_L"], roles["UpperLeg_R"])
        top = "Shoulder" if roles["Shoulder_L"] is not None else "UpperArm"
        chest = _lca(sk, roles[f"{top}_L"], roles[f"{top}_R"])
        head = heads[0]
        if chest == hips or hips not in _ancestors(sk, chest) or chest not in _ancestors(sk, head) or head == chest:
            continue
        path = _ancestors(sk, chest)
        spine_path = path[: path.index(hips)][::-1]  # from above the hips up to the chest
        head_path = _ancestors(sk, head)
        neck = head_path[head_path.index(chest) - 1]
        roles.update({"Hips": hips, "Chest": chest, "Head": head, "Neck": None if neck == head else neck,
                      "Spine": spine_path[0] if spine_path[0] != chest else None})
        return convention, roles
    return None


def _chains_agree(sk: Skeleton, roles: dict[str, int | None]) -> bool:
    """Each named limb joint hangs below the one before it (shoulder, upper arm, forearm, hand; thigh ...)."""
    for s in ("_L", "_R"):
        for chain in (("Shoulder", "UpperArm", "LowerArm", "Hand"), ("UpperLeg", "LowerLeg", "Foot", "Toes")):
            joints = [roles[r + s] for r in chain if roles[r + s] is not None]
            if any(a not in _ancestors(sk, b)[1:] for a, b in itertools.pairwise(joints)):
                return False
    return True
