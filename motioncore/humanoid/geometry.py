"""One pose of a skeleton read as geometry: positions, end sites, subtrees, chains, mirror-image limbs.

Lengths *along the bones* (:attr:`_Geometry.depth`, :meth:`_Geometry.along`) do not change with the
pose; straight-line distances between joints that a bent joint separates do. The mapping decides
from the former wherever it can.
"""
from __future__ import annotations

from dataclasses import dataclass

import torch

from motioncore import quat
from motioncore.kinematics import rest_positions
from motioncore.skeleton import Skeleton


class NotHumanoidError(ValueError):
    """No humanoid found; the message names the roles that could not be found and why."""


class _Geometry:
    """Joint positions and end-site tips of one pose (default: the rest pose), subtrees and chains."""

    def __init__(self, sk: Skeleton, pos: torch.Tensor | None = None, grot: torch.Tensor | None = None):
        self.sk = sk
        self.pose = "rest pose" if pos is None else "pose read"  # what errors call it
        self.pos = rest_positions(sk.offsets.double(), sk.parents) if pos is None else pos.double()
        self.sites = {j: (e.double() if grot is None else quat.mul_vec(grot[j].double(), e.double()))
                      for j, e in sk.end_sites.items() if 0 <= j < sk.num_joints}
        self.children: list[list[int]] = [[] for _ in range(sk.num_joints)]
        for j in range(1, sk.num_joints):
            self.children[sk.parents[j]].append(j)
        self.subtree: list[list[int]] = [[j] for j in range(sk.num_joints)]
        for j in reversed(range(1, sk.num_joints)):
            self.subtree[sk.parents[j]].extend(self.subtree[j])
        parents = [max(p, 0) for p in sk.parents]
        bones = (self.pos - self.pos[parents]).norm(dim=-1).tolist()
        rest_bones = sk.offsets.double().norm(dim=-1).tolist()
        self.depth = [0.0] * sk.num_joints  # length along the bones from the root, in this pose
        rest_depth = [0.0] * sk.num_joints
        for j in range(1, sk.num_joints):
            self.depth[j] = self.depth[sk.parents[j]] + bones[j]
            rest_depth[j] = rest_depth[sk.parents[j]] + rest_bones[j]
        self.site_len = {j: float(e.norm()) for j, e in self.sites.items()}
        longest = max(rest_depth[j] + self.site_len.get(j, 0.0) for j in range(sk.num_joints))
        self.eps = 0.004 * (longest or 1.0)  # joints closer than this coincide (the same in every pose)
        self._farthest: list[int] | None = None
        self.size = 250 * self.eps  # a first guess of the figure's size; the legs' length sets it once known

    def extent(self, j: int) -> float:
        """Size (largest axis extent) of the subtree of ``j`` in this pose, end sites included."""
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

    def tip_depth(self, j: int) -> float:
        """Length along the bones from the root to the end of ``j``: its End Site's tip, else the joint."""
        return self.depth[j] + self.site_len.get(j, 0.0)

    def along(self, a: int, b: int | None) -> float:
        """Length along the bones from joint ``a`` down to joint ``b`` (None: to ``a``'s End Site tip)."""
        return (self.tip_depth(a) if b is None else self.depth[b]) - self.depth[a]

    def farthest(self, child: int) -> tuple[int, torch.Tensor]:
        """The joint of ``child``'s subtree whose end is farthest along the bones (the longest finger's tip,
        whatever the pose), and that end: its End Site's tip, else the joint."""
        if self._farthest is None:  # every subtree's, in one pass from the leaves up
            best = [(self.tip_depth(j), j) for j in range(self.sk.num_joints)]
            for j in reversed(range(1, self.sk.num_joints)):
                p = self.sk.parents[j]
                if best[j][0] > best[p][0]:
                    best[p] = best[j]
            self._farthest = [j for _, j in best]
        end = self._farthest[child]
        return end, self.points(end)[-1]

    def chain(self, top: int, child: int) -> tuple[list[int], torch.Tensor]:
        """Path from ``top`` to the farthest point of ``child``'s subtree, and that point."""
        end, tip = self.farthest(child)
        return self.path(top, end), tip

    def bone_lengths(self, top: int, chain: list[int], tip: torch.Tensor) -> list[float]:
        pts = torch.cat([self.pos[[top] + chain], tip[None]])
        return [x for x in (pts[1:] - pts[:-1]).norm(dim=-1).tolist() if x > self.eps]


@dataclass
class _Pair:
    parent: int
    a: int  # child joints starting the two limbs
    b: int
    length: float  # along the bones from the parent to the limb's farthest tip (the same in every pose)
    tips: tuple[torch.Tensor, torch.Tensor]  # those tips in the pose read


def _limb_pairs(g: _Geometry) -> list[_Pair]:
    """Sibling subtrees whose chains start with the same bone lengths (mirror images; a hand may have fingers
    the other lacks) and are at least a quarter of their parent's subtree long."""
    pairs = []
    for h in range(g.sk.num_joints):
        kids = g.children[h]
        if len(kids) < 2:
            continue
        size = max(g.tip_depth(j) for j in g.subtree[h]) - g.depth[h]
        limbs = {}
        for a in kids:
            ca, ta = g.chain(h, a)
            limbs[a] = (ta, g.bone_lengths(h, ca, ta))
        for i, a in enumerate(kids):
            ta, la = limbs[a]
            length = sum(la)
            if length < 0.25 * size or len(la) < 3:
                continue
            for b in kids[i + 1:]:
                tb, lb = limbs[b]
                n = min(len(la), len(lb))
                if n >= 3 and abs(len(la) - len(lb)) <= 2 and \
                        all(abs(x - y) <= 0.12 * max(x, y) + 2 * g.eps for x, y in zip(la[:n], lb[:n])):
                    pairs.append(_Pair(h, a, b, length, (ta, tb)))
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
