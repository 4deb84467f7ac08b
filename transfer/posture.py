"""Where a style puts the body, applied after the style's change (:func:`transfer.apply.apply_style_features`):
the example's posture drawn onto the result (:func:`match_posture`), bounded between where the content and the
example hold each joint (:func:`posture_between`); a neutral pair held where the example or neutral clips
hold each joint (:func:`bound_pair`, while learning); an arm doing what the example's never does kept as the content's
(:func:`arm_gate`, off by default); and the arms of a clip done in place under a travelling example's style
(:func:`arm_motion_share`, :func:`keep_arm_motion`). Features ``(T, D)``, normalised unless a function says raw."""
from __future__ import annotations

import torch

from motioncore.limbs import hand_reach
from motioncore.representation import FEATURES
from motioncore.skeleton import CANONICAL
from transfer.edit import smooth_time
from transfer.style_losses import STAT_CHANNELS

ARM_GATE_WIDTH = 0.2  # metres over which an arm's share of the style falls from all to none (arm_gate)
ARM_GATE_SMOOTHING = 5.0  # frames: Gaussian sigma of the gate over time, so an arm eases in and out of the style
ARM_JOINTS = ("Shoulder", "UpperArm", "LowerArm", "Hand")  # an arm's joints, "_L"/"_R" after each (gate_arms)


def arm_channels(side: str) -> list[int]:
    """The feature channels (positions and rotations) of one arm's :data:`ARM_JOINTS`, ``side`` "L" or "R"."""
    return FEATURES.joint_channels([CANONICAL.skeleton.index(f"{n}_{side}") for n in ARM_JOINTS])


def arm_gate(content: torch.Tensor, example: torch.Tensor, radius: float) -> torch.Tensor:
    """How much of the style each arm of ``content`` takes, frame by frame: all while its hand is within
    ``radius`` metres of a place the style ``example``'s hand ever takes (:func:`motioncore.limbs.hand_reach`;
    both raw features, ``(T, D)`` and ``(T', D)``), none past ``radius + ARM_GATE_WIDTH``, smoothed over time ->
    ``(T, 2)`` in [0, 1], left then right. A style learned from a walk says nothing of how to raise the hands."""
    if radius <= 0:
        raise ValueError(f"arm_gate: expected a radius above 0, got {radius}")
    w = (1 - (hand_reach(content, example) - radius) / ARM_GATE_WIDTH).clamp(0, 1)
    return smooth_time(w[None], ARM_GATE_SMOOTHING)[0].clamp(0, 1)


def gate_arms(out: torch.Tensor, content: torch.Tensor, weights: torch.Tensor) -> torch.Tensor:
    """``out (T, D)``, stylised from ``content (T, D)`` (features, normalised or not alike), with each arm's
    channels (shoulder to hand, positions and rotations) kept ``weights (T, 2)`` of the style's change (left,
    right; :func:`arm_gate`) and the rest taken back to the content's."""
    if out.shape != content.shape or weights.shape != (out.shape[0], 2):
        raise ValueError(f"gate_arms: expected out and content (T, D) alike and weights (T, 2), got "
                         f"{tuple(out.shape)}, {tuple(content.shape)}, {tuple(weights.shape)}")
    out = out.clone()
    for side, w in zip("LR", weights.T.to(out)):
        ch = arm_channels(side)
        out[:, ch] = content[:, ch] + w[:, None] * (out[:, ch] - content[:, ch])
    return out


ARM_TRAVEL_MIN = 0.2  # m/s: an example that travels slower over the ground is done in place (arm_motion_share)


def ground_speed(feats: torch.Tensor) -> float:
    """Mean speed of the root over the ground, raw features ``(T, D)`` at the canonical fps -> m/s."""
    if feats.ndim != 2 or feats.shape[1] != FEATURES.dim:
        raise ValueError(f"ground_speed: expected raw features (T, {FEATURES.dim}), got {tuple(feats.shape)}")
    return float(feats[:, FEATURES.root_lvel].norm(dim=-1).mean()) * CANONICAL.fps


def arm_motion_share(content: torch.Tensor, example: torch.Tensor, travel: float) -> float:
    """How much of the style's change over time the arms of ``content`` take (beyond its time-mean, the posture;
    :func:`keep_arm_motion`), both raw features ``(T, D)``, ``(T', D)``: all when the example is done in place
    (slower than :data:`ARM_TRAVEL_MIN`) or the content travels at least ``travel`` times the example's ground
    speed, less in proportion below that. How a walk swings its arms says nothing of how a wave moves them."""
    if travel <= 0:
        raise ValueError(f"arm_motion_share: expected a travel share above 0, got {travel}")
    v_example = ground_speed(example)
    if v_example < ARM_TRAVEL_MIN:
        return 1.0
    return min(1.0, ground_speed(content) / (travel * v_example))


def keep_arm_motion(out: torch.Tensor, content: torch.Tensor, share: float,
                    held: torch.Tensor | None = None) -> torch.Tensor:
    """``out (T, D)``, stylised from ``content (T, D)`` (features, normalised or not alike), with each arm's
    channels (shoulder to hand, positions and rotations) keeping ``share`` of the style's change around its
    time-mean: the arm moves as the content moves it, held where the style holds it. With ``held (D,)`` (the
    example's own change against its pair, :func:`posture_channels`), the held change goes ``1 - share`` of the
    way from the style model's time-mean to it: what a walk's model does to an arm that waves is not the style."""
    if out.shape != content.shape or out.ndim != 2:
        raise ValueError(f"keep_arm_motion: expected out and content (T, D) alike, got {tuple(out.shape)}, "
                         f"{tuple(content.shape)}")
    if held is not None and held.shape != (out.shape[1],):
        raise ValueError(f"keep_arm_motion: expected held ({out.shape[1]},), got {tuple(held.shape)}")
    if share >= 1:
        return out
    out = out.clone()
    for side in "LR":
        ch = arm_channels(side)
        change = out[:, ch] - content[:, ch]
        mean = change.mean(0, keepdim=True)
        target = mean if held is None else share * mean + (1 - share) * held[ch]
        out[:, ch] = content[:, ch] + target + share * (change - mean)
    return out


def posture_channels(posture_shift: torch.Tensor, dim: int, amount: float = 1.0) -> torch.Tensor:
    """A style's ``posture_shift (C,)`` (over :data:`transfer.style_losses.STAT_CHANNELS`) times ``amount``, placed
    in a ``(dim,)`` vector of feature channels (0 elsewhere)."""
    if posture_shift.shape != (len(STAT_CHANNELS),):
        raise ValueError(f"posture_channels: expected a shift ({len(STAT_CHANNELS)},), got {tuple(posture_shift.shape)}")
    full = posture_shift.new_zeros(dim)
    full[STAT_CHANNELS.to(full.device)] = amount * posture_shift
    return full


POSTURE_TOLERANCE = 0.1  # normalised units a posture may carry a channel's time-mean past the content's and the example's


def posture_between(posture_shift: torch.Tensor, content: torch.Tensor, example: torch.Tensor,
                    amount: float = 1.0) -> torch.Tensor:
    """A style's ``posture_shift (C,)`` (the example's time-mean change against its neutral pair, over
    :data:`transfer.style_losses.STAT_CHANNELS`) cut, channel by channel, so that ``amount`` of it takes the time-mean
    of ``content (T, D)`` no further than :data:`POSTURE_TOLERANCE` past where the content and the ``example (T', D)``
    (both normalised) hold that channel: a posture moves a joint from the content's towards the example's, not
    elsewhere. A neutral pair drawn with a tilt that neither clip has (a pelvis rolled 18 degrees) says "untilt";
    carried whole, that tilts the result."""
    if posture_shift.shape != (len(STAT_CHANNELS),):
        raise ValueError(f"posture_between: expected a shift ({len(STAT_CHANNELS)},), got {tuple(posture_shift.shape)}")
    if content.ndim != 2 or example.ndim != 2 or content.shape[1] != example.shape[1]:
        raise ValueError(f"posture_between: expected content and example (T, D), got {tuple(content.shape)}, "
                         f"{tuple(example.shape)}")
    if amount <= 0:
        return posture_shift
    ch = STAT_CHANNELS.to(content.device)
    m_c, m_e = content[:, ch].mean(0), example[:, ch].mean(0)
    low, high = torch.minimum(m_c, m_e) - POSTURE_TOLERANCE, torch.maximum(m_c, m_e) + POSTURE_TOLERANCE
    return ((m_c + amount * posture_shift).clamp(low, high) - m_c) / amount


PAIR_SPREAD = 2.0  # standard deviations of the neutral clips' time-means that count as where they hold a channel


def bound_pair(pair: torch.Tensor, example: torch.Tensor, neutral: list[torch.Tensor]) -> torch.Tensor:
    """The neutral ``pair (T, D)`` of ``example (T, D)`` with each body channel's time-mean
    (:data:`transfer.style_losses.STAT_CHANNELS`) brought within :data:`POSTURE_TOLERANCE` of the span from where the
    example holds it to where neutral clips of its action hold it (``neutral``: normalised ``(T_i, D)``; their
    time-means' mean +- :data:`PAIR_SPREAD` standard deviations), by a constant offset. A pair is the example done
    neutrally: a tilt that neither the example nor neutral clips have (a pelvis the prior drew rolled 18 degrees)
    would be learned as the style's. No neutral clips: the pair as it is."""
    if pair.ndim != 2 or pair.shape != example.shape or pair.shape[-1] != FEATURES.dim:
        raise ValueError(f"bound_pair: expected pair and example (T, {FEATURES.dim}) alike, got {tuple(pair.shape)} "
                         f"and {tuple(example.shape)}")
    if not neutral:
        return pair
    ch = STAT_CHANNELS.to(pair.device)
    means = torch.stack([x[:, ch].mean(0).to(pair) for x in neutral])
    centre = means.mean(0)
    spread = PAIR_SPREAD * means.std(0, unbiased=False)
    m_e, m_p = example[:, ch].mean(0), pair[:, ch].mean(0)
    low = torch.minimum(m_e, centre - spread) - POSTURE_TOLERANCE
    high = torch.maximum(m_e, centre + spread) + POSTURE_TOLERANCE
    out = pair.clone()
    out[:, ch] += m_p.clamp(low, high) - m_p
    return out


def match_posture(out: torch.Tensor, content: torch.Tensor, posture_shift: torch.Tensor, weight: float,
                  amount: float = 1.0) -> torch.Tensor:
    """``out (T, D)``, stylised from ``content (T, D)`` (normalised), with the time-mean change of its body channels
    (:data:`transfer.style_losses.STAT_CHANNELS`) blended by ``weight`` towards ``amount * posture_shift (C,)``, the
    example's time-mean change against its neutral pair: a constant offset per channel, so how the content moves is
    kept and where it holds each joint follows the example."""
    if posture_shift.shape != (len(STAT_CHANNELS),):
        raise ValueError(f"match_posture: expected a shift ({len(STAT_CHANNELS)},), got {tuple(posture_shift.shape)}")
    ch = STAT_CHANNELS.to(out.device)
    change = out[:, ch].mean(0) - content[:, ch].mean(0)
    out = out.clone()
    out[:, ch] += weight * (amount * posture_shift.to(out) - change)
    return out
