"""The joints of each limb, the head, and which side is left, once the legs and arms are known.

Lengths are measured along the bones, so a bent knee or elbow, an arm folded at the chest or raised
overhead, reads like a straight one. ``up`` is the body's own up (hips toward chest in the pose
read), not the world's, so a leaning, sitting or lying figure reads like a standing one.
"""
from __future__ import annotations

import math

import torch

from motioncore.humanoid.geometry import NotHumanoidError, _distinct, _Geometry
from motioncore.humanoid.names import core, name_side

_LEG = {"ratio": 1.0, "length": 0.5, "foot": 0.5}  # thigh/shin, (thigh+shin)/figure size, ankle-to-toe-tip/shin


def _leg(g: _Geometry, hips: int, child: int, side: str) -> tuple[dict, dict]:
    chain, _ = g.chain(hips, child)
    pts = _distinct(g, chain, g.pos[hips])
    if len(pts) < 3:
        raise NotHumanoidError(f"the {side} leg has {len(pts)} bones; a leg needs hip, knee and ankle: "
                               "UpperLeg, LowerLeg and Foot not found")
    upper = pts[0]
    best = None
    for k in range(1, len(pts)):
        for w in range(k + 1, len(pts)):
            l1, l2 = g.along(upper, pts[k]), g.along(pts[k], pts[w])
            cost = 4 * math.log(l1 / l2 / _LEG["ratio"]) ** 2 + math.log((l1 + l2) / g.size / _LEG["length"]) ** 2
            l3 = g.tip_depth(chain[-1]) - g.depth[pts[w]]  # a foot beyond the ankle
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
    chain, _ = g.chain(chest, child)
    pts = _distinct(g, chain, g.pos[chest])
    if len(pts) < 3:
        raise NotHumanoidError(f"the {side} arm has {len(pts)} bones; an arm needs shoulder, elbow and wrist: "
                               "UpperArm, LowerArm and Hand not found")
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
                l1, l2 = g.along(pts[i], pts[k]), g.along(pts[k], pts[w])
                cost = 4 * math.log(l1 / l2 / _ARM["ratio"]) ** 2
                cost += math.log((l1 + l2) / g.size / _ARM["length"]) ** 2
                l3 = g.tip_depth(chain[-1]) - g.depth[pts[w]]  # a hand beyond the wrist (Bandai's hands end at it)
                cost += min(1.0, math.log(l3 / l2 / _ARM["hand"]) ** 2) if l3 > g.eps else 0.0
                cost -= 0.3 * sum(core(g.sk.names[pts[x]]) in _NAMES[r] for x, r in zip((i, k, w), _NAMES))
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
        raise NotHumanoidError("nothing above the chest but the arms: Neck and Head not found")
    height = lambda p: float(p @ up)
    arms = {j for a in arm_children for j in g.subtree[a]}  # a raised hand is not the top of the head
    cands = [(height(p), j, p) for c in kids for j in g.subtree[c] if j not in arms for p in g.points(j)]
    _, end, top = max(cands, key=lambda t: t[0])
    path = g.path(chest, end)
    named = [j for j in path if core(g.sk.names[j]).endswith("head")]  # Head, head, Bip01 Head, J_Bip_C_Head
    if len(named) == 1:
        head, how = named[0], "named head"
    elif float(g.sites.get(end, torch.zeros(3)).norm()) <= g.eps and not g.children[end] and \
            float(g.sk.offsets[end].norm()) < 0.08 * g.size:
        head, how = end, "top of the neck chain, a short bone with nothing above it"  # SMPL's head
    else:
        tall = [j for j in path if height(top) - height(g.pos[j]) >= 0.04 * g.size]
        if not tall:
            raise NotHumanoidError("Head not found: nothing above the chest reaches a head's height above the neck")
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
    """Facing direction (unit, across ``up``) from the feet (ankle -> toe, or the foot's End Site), None when
    they do not show it."""
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


def _sides(g: _Geometry, parent: int, limbs: tuple[int, int], sockets: tuple[int, int], left: torch.Tensor | None,
           what: str) -> tuple[int, int, str]:
    """(left child, right child, how) of a limb pair: by where its sockets (hip or shoulder joint) sit when
    ``left`` is known -- hands may cross the body, sockets do not -- else by names."""
    a, b = limbs
    if left is not None:
        da, db = (float((g.pos[s] - g.pos[parent]) @ left) for s in sockets)
        if abs(da - db) > g.eps:
            return (a, b, "left by geometry") if da > db else (b, a, "left by geometry")
    votes = [sum(name_side(g.sk.names[j]) for j in g.subtree[c]) for c in (a, b)]
    if votes[0] > 0 > votes[1] or votes[1] > 0 > votes[0]:
        return (a, b, "left by name") if votes[0] > 0 else (b, a, "left by name")
    roles = "UpperLeg, LowerLeg, Foot, Toes" if what == "leg" else "Shoulder, UpperArm, LowerArm, Hand"
    raise NotHumanoidError(f"cannot tell the left {what} from the right ({roles} _L or _R?): the feet do not show "
                           "which way the figure faces and the joint names do not say left/right")
