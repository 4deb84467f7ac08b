"""Forward kinematics over any leading dims."""
from __future__ import annotations

from collections.abc import Sequence

import torch

from motioncore import quat


def fk(lrot: torch.Tensor, lpos: torch.Tensor, parents: Sequence[int]) -> tuple[torch.Tensor, torch.Tensor]:
    """Local rotations ``(*, J, 4)`` and local positions ``(*, J, 3)`` -> ``(grot, gpos)``.

    ``lpos[..., 0, :]`` is the root's global position; the others are offsets in the parent frame.
    Parents must precede children.
    """
    j = len(parents)
    if lrot.shape[-2:] != (j, 4) or lpos.shape[-2:] != (j, 3) or lrot.shape[:-1] != lpos.shape[:-1]:
        raise ValueError(f"fk: expected lrot (*, {j}, 4) and lpos (*, {j}, 3), got {tuple(lrot.shape)} and {tuple(lpos.shape)}")
    grot, gpos = [lrot[..., 0, :]], [lpos[..., 0, :]]
    for i in range(1, j):
        p = parents[i]
        gpos.append(gpos[p] + quat.mul_vec(grot[p], lpos[..., i, :]))
        grot.append(quat.mul(grot[p], lrot[..., i, :]))
    return torch.stack(grot, dim=-2), torch.stack(gpos, dim=-2)


def to_local(grot: torch.Tensor, parents: Sequence[int]) -> torch.Tensor:
    """Global rotations ``(*, J, 4)`` -> local rotations ``(*, J, 4)``."""
    if grot.shape[-2] != len(parents):
        raise ValueError(f"to_local: expected (*, {len(parents)}, 4), got {tuple(grot.shape)}")
    par = torch.tensor([max(p, 0) for p in parents])
    lrot = quat.mul(quat.inv(grot[..., par, :]), grot)
    lrot[..., 0, :] = grot[..., 0, :]
    return lrot


def rest_positions(offsets: torch.Tensor, parents: Sequence[int]) -> torch.Tensor:
    """Global joint positions ``(J, 3)`` of the rest pose (all rotations identity)."""
    pos = [offsets[0] * 0]
    for i in range(1, len(parents)):
        pos.append(pos[parents[i]] + offsets[i])
    return torch.stack(pos)
