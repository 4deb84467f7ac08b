"""How much a motion's planted feet slide (foot skating): the measure the evaluation protocol reports and apply
tells the user before and after its IK foot cleanup."""
from __future__ import annotations

from collections.abc import Sequence

import torch

from motioncore.motion import Motion
from motioncore.skeleton import CANONICAL, CanonicalSpec

SKATING_HEIGHT = 0.03  # metres above the joint's lowest point (see foot_skating_ratio)
SKATING_SPEED = 0.5  # metres per second horizontally (2.5 cm per frame at 20 fps)


def skating_frames(positions: torch.Tensor, fps: float, height: float = SKATING_HEIGHT, speed: float = SKATING_SPEED,
                   spec: CanonicalSpec = CANONICAL) -> torch.Tensor:
    """``(T - 1,)`` bool: transition ``t -> t+1`` skates (definition in :func:`foot_skating_ratio`)."""
    slide = skating_feet(positions, fps, height, speed, spec)
    return slide[:, 0] | slide[:, 1]


def skating_feet(positions: torch.Tensor, fps: float, height: float = SKATING_HEIGHT, speed: float = SKATING_SPEED,
                 spec: CanonicalSpec = CANONICAL) -> torch.Tensor:
    """``(T - 1, 2)`` bool: the left, the right foot skates on transition ``t -> t+1`` of ``positions (T, J, 3)``
    (definition in :func:`foot_skating_ratio`)."""
    if positions.ndim != 3 or positions.shape[1:] != (spec.num_joints, 3) or positions.shape[0] < 2:
        raise ValueError(f"foot_skating_ratio: expected positions (T >= 2, {spec.num_joints}, 3), got {tuple(positions.shape)}")
    feet = positions[:, list(spec.feet)].double()  # (T, 4, 3): Foot_L, Toes_L, Foot_R, Toes_R
    h = feet[..., 1] - feet[..., 1].amin(0)  # each joint's height above its own lowest point in the clip
    low = (h[1:] < height) & (h[:-1] < height)
    fast = (feet[1:, :, [0, 2]] - feet[:-1, :, [0, 2]]).norm(dim=-1) * fps > speed
    slide = low & fast  # (T - 1, 4)
    return torch.stack([slide[:, 0] & slide[:, 1], slide[:, 2] & slide[:, 3]], 1)  # a whole foot (ankle and toes)


def foot_skating_ratio(positions: torch.Tensor | Sequence[torch.Tensor], fps: float = CANONICAL.fps,
                       height: float = SKATING_HEIGHT, speed: float = SKATING_SPEED, spec: CanonicalSpec = CANONICAL) -> float:
    """Fraction of frame transitions in which a planted foot slides; pooled over clips when given a list.

    ``positions``: global joint positions ``(T, J, 3)`` (metres, Y-up) on the canonical skeleton,
    e.g. ``decode_positions`` of raw features, or a list of them. Definition, per clip:

    - a foot is its two contact joints of ``spec.feet``: (Foot_L, Toes_L) and (Foot_R, Toes_R);
    - a joint's height is its y above its own lowest y in the clip (so the ankle, which sits
      higher than the toes when planted, reads 0 when planted, and a clip that floats or sinks
      as a whole is judged like one on the floor);
    - a foot skates on transition ``t -> t+1`` if *both* its joints are below ``height`` (3 cm) at
      both frames while *both* move horizontally (xz) faster than ``speed`` (0.5 m/s, i.e. 2.5 cm
      per frame at 20 fps). Requiring the whole foot keeps the swing toe skimming the floor, the
      heel strike and the toe pivot from counting (with the toes alone, real walking scores ~30 %);
    - a transition skates if either foot skates; the ratio is skating transitions over all
      transitions (summed over clips, so long clips weigh more).

    A planted foot scores 0, a flat foot sliding along the floor for the whole clip 1. On the
    Bandai-2 test originals real locomotion scores about 5 % and gestures 0 %.
    """
    clips = [positions] if torch.is_tensor(positions) else list(positions)
    if not clips:
        raise ValueError("foot_skating_ratio: no clips")
    skating = total = 0
    for p in clips:
        s = skating_frames(p, fps, height, speed, spec)
        skating += int(s.sum())
        total += s.numel()
    return skating / total


def motion_skating(motion: Motion) -> float:
    """:func:`foot_skating_ratio` of a canonical motion (its global positions at its own fps)."""
    return foot_skating_ratio(motion.global_positions(), motion.fps)
