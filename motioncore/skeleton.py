"""Skeletons (joint names, parents, rest offsets) and the canonical skeleton spec.

The canonical skeleton is Y-up, metres, facing +Z in its rest pose, which is a T-pose
(left arm along +X). Its 21 joints follow the Bandai-Namco layout minus ``joint_Root``,
a ground marker with no bone whose role the root features of the representation play;
every source skeleton we support (Bandai, CMU/Xia, AnimatedDrawings, Mixamo, BlazePose)
can fill all of them.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import torch


@dataclass(frozen=True)
class Skeleton:
    """Joint hierarchy. ``offsets (J, 3)`` metres in the parent's frame; ``parents[0] == -1``.

    Parents always come before children.
    """

    names: tuple[str, ...]
    parents: tuple[int, ...]
    offsets: torch.Tensor
    end_sites: dict[int, torch.Tensor] = field(default_factory=dict)

    def __post_init__(self) -> None:
        j = len(self.names)
        if len(self.parents) != j or tuple(self.offsets.shape) != (j, 3):
            raise ValueError(
                f"Skeleton: expected {j} parents and offsets (J, 3)=({j}, 3), "
                f"got {len(self.parents)} parents and offsets {tuple(self.offsets.shape)}"
            )
        for i, p in enumerate(self.parents):
            if not (p == -1 if i == 0 else 0 <= p < i):
                raise ValueError(f"Skeleton: joint {i} ({self.names[i]}) has parent {p}; expected parents before children")
        if len(set(self.names)) != j:
            raise ValueError("Skeleton: joint names must be unique")

    @property
    def num_joints(self) -> int:
        return len(self.names)

    def index(self, name: str) -> int:
        try:
            return self.names.index(name)
        except ValueError:
            raise KeyError(f"joint {name!r} not in skeleton ({', '.join(self.names)})") from None

    def children(self, j: int) -> list[int]:
        return [i for i, p in enumerate(self.parents) if p == j]


@dataclass(frozen=True)
class CanonicalSpec:
    """The canonical skeleton plus the named joint groups the rest of the code relies on."""

    skeleton: Skeleton
    fps: float
    mirror: tuple[int, ...]  # index of each joint's left/right counterpart
    feet: tuple[int, ...]  # contact joints: Foot_L, Toes_L, Foot_R, Toes_R
    hips_lr: tuple[int, int]  # UpperLeg_L, UpperLeg_R (facing direction)
    shoulders_lr: tuple[int, int]  # UpperArm_L, UpperArm_R
    legs: tuple[tuple[int, int, int], ...]  # (hip, knee, ankle) for left, right

    @property
    def num_joints(self) -> int:
        return self.skeleton.num_joints


_CANON = [
    # name, parent, offset in metres (T-pose, Y-up, facing +Z, left = +X)
    ("Hips", None, (0.0, 0.0, 0.0)),
    ("Spine", "Hips", (0.0, 0.13, 0.0)),
    ("Chest", "Spine", (0.0, 0.11, 0.0)),
    ("Neck", "Chest", (0.0, 0.19, 0.0)),
    ("Head", "Neck", (0.0, 0.09, 0.0)),
    ("Shoulder_L", "Chest", (0.04, 0.14, 0.0)),
    ("UpperArm_L", "Shoulder_L", (0.13, 0.0, 0.0)),
    ("LowerArm_L", "UpperArm_L", (0.26, 0.0, 0.0)),
    ("Hand_L", "LowerArm_L", (0.24, 0.0, 0.0)),
    ("Shoulder_R", "Chest", (-0.04, 0.14, 0.0)),
    ("UpperArm_R", "Shoulder_R", (-0.13, 0.0, 0.0)),
    ("LowerArm_R", "UpperArm_R", (-0.26, 0.0, 0.0)),
    ("Hand_R", "LowerArm_R", (-0.24, 0.0, 0.0)),
    ("UpperLeg_L", "Hips", (0.09, -0.06, 0.0)),
    ("LowerLeg_L", "UpperLeg_L", (0.0, -0.41, 0.0)),
    ("Foot_L", "LowerLeg_L", (0.0, -0.41, 0.0)),
    ("Toes_L", "Foot_L", (0.0, -0.05, 0.13)),
    ("UpperLeg_R", "Hips", (-0.09, -0.06, 0.0)),
    ("LowerLeg_R", "UpperLeg_R", (0.0, -0.41, 0.0)),
    ("Foot_R", "LowerLeg_R", (0.0, -0.41, 0.0)),
    ("Toes_R", "Foot_R", (0.0, -0.05, 0.13)),
]


def _build_canonical() -> CanonicalSpec:
    names = tuple(n for n, _, _ in _CANON)
    parents = tuple(-1 if p is None else names.index(p) for _, p, _ in _CANON)
    offsets = torch.tensor([o for _, _, o in _CANON], dtype=torch.float32)
    sk = Skeleton(names, parents, offsets, end_sites={names.index("Head"): torch.tensor([0.0, 0.1, 0.0])})

    def swap(n: str) -> str:
        return n[:-1] + {"L": "R", "R": "L"}[n[-1]] if n.endswith(("_L", "_R")) else n

    mirror = tuple(names.index(swap(n)) for n in names)
    ix = names.index
    return CanonicalSpec(
        skeleton=sk,
        fps=20.0,
        mirror=mirror,
        feet=(ix("Foot_L"), ix("Toes_L"), ix("Foot_R"), ix("Toes_R")),
        hips_lr=(ix("UpperLeg_L"), ix("UpperLeg_R")),
        shoulders_lr=(ix("UpperArm_L"), ix("UpperArm_R")),
        legs=((ix("UpperLeg_L"), ix("LowerLeg_L"), ix("Foot_L")), (ix("UpperLeg_R"), ix("LowerLeg_R"), ix("Foot_R"))),
    )


CANONICAL = _build_canonical()
"""The project's one canonical skeleton: 21 joints, Y-up, metres, 20 fps."""
