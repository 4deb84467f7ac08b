"""Feet and smoothness of a canonical motion (issue 50): contacts with hysteresis, and the measures the foot
cleanup is held to (drift per contact, peak joint acceleration, the worst single-frame jump of a foot in contact,
the feet's height at contacts, swing clearance).

Contacts are per foot joint of :attr:`motioncore.skeleton.CanonicalSpec.feet` (Foot_L, Toes_L, Foot_R, Toes_R: heel
and toe of each foot). A joint enters a contact where it is low and slow (:attr:`ContactConfig.height_on`,
``speed_on``) and stays in it while it is not clearly high or fast (``height_off``, ``speed_off``): one noisy frame
neither starts nor breaks a contact; gaps of up to :attr:`ContactConfig.fill_frames` frames are filled. Heights are
above each joint's own floor (its lowest height over the motion, or a take's, ``floor``): the ankle's own lowest
place, not the toes' (:func:`motioncore.representation.foot_contacts` also takes off the ankle's rest height above
the toes, so that an ankle reads as low 5 cm higher up).
"""
from __future__ import annotations

from dataclasses import dataclass
from itertools import pairwise

import torch

from motioncore.skeleton import CANONICAL, CanonicalSpec


@dataclass(frozen=True)
class ContactConfig:
    """Thresholds of a contact with hysteresis (metres, metres per second) and its shortest run (frames)."""

    height_on: float = 0.05
    speed_on: float = 0.25
    height_off: float = 0.07
    speed_off: float = 0.30
    min_frames: int = 2  # runs shorter than this are dropped
    fill_frames: int = 2  # gaps between two runs of at most this many frames are filled


def _check_positions(gpos: torch.Tensor, spec: CanonicalSpec, name: str) -> None:
    if gpos.ndim != 3 or gpos.shape[1:] != (spec.num_joints, 3):
        raise ValueError(f"{name}: expected positions (T, {spec.num_joints}, 3), got {tuple(gpos.shape)}")


def foot_heights(gpos: torch.Tensor, spec: CanonicalSpec = CANONICAL, floor: torch.Tensor | None = None) -> torch.Tensor:
    """``(T, 4)``: each foot joint's height above its floor (``floor (4,)``: its lowest height; default over
    ``gpos (T, J, 3)``)."""
    _check_positions(gpos, spec, "foot_heights")
    y = gpos[:, list(spec.feet), 1]
    floor = y.amin(0) if floor is None else floor.to(y)
    return y - floor


def foot_speeds(gpos: torch.Tensor, fps: float, spec: CanonicalSpec = CANONICAL) -> torch.Tensor:
    """``(T, 4)``: each foot joint's speed (m/s), frame ``t`` to ``t+1`` (the last frame repeats the one before)."""
    _check_positions(gpos, spec, "foot_speeds")
    feet = gpos[:, list(spec.feet)]
    if feet.shape[0] < 2:
        return torch.zeros(feet.shape[:2], dtype=feet.dtype)
    v = (feet[1:] - feet[:-1]).norm(dim=-1) * fps
    return torch.cat([v, v[-1:]])


def _fill_and_drop(flags: torch.Tensor, min_frames: int, fill_frames: int) -> torch.Tensor:
    """``flags (T,)`` with gaps of at most ``fill_frames`` between runs filled, then runs shorter than ``min_frames``
    dropped."""
    out = flags.clone()
    runs = contact_runs(out)
    for (_, e0), (s1, _) in pairwise(runs):
        if s1 - e0 <= fill_frames:
            out[e0:s1] = True
    for s, e in contact_runs(out):
        if e - s < min_frames:
            out[s:e] = False
    return out


def contact_flags(gpos: torch.Tensor, fps: float, spec: CanonicalSpec = CANONICAL, floor: torch.Tensor | None = None,
                  config: ContactConfig = ContactConfig()) -> torch.Tensor:
    """Contacts with hysteresis, bool ``(T, 4)`` for (Foot_L, Toes_L, Foot_R, Toes_R) of positions ``gpos (T, J, 3)``
    (see the module's docstring; ``floor (4,)``: the joints' lowest heights over a take)."""
    _check_positions(gpos, spec, "contact_flags")
    h, v = foot_heights(gpos, spec, floor), foot_speeds(gpos, fps, spec)
    on = (h < config.height_on) & (v < config.speed_on)
    hold = (h < config.height_off) & (v < config.speed_off)
    out = torch.zeros_like(on)
    state = torch.zeros(on.shape[1], dtype=torch.bool)
    for t in range(on.shape[0]):
        state = on[t] | (state & hold[t])
        out[t] = state
    for j in range(out.shape[1]):
        out[:, j] = _fill_and_drop(out[:, j], config.min_frames, config.fill_frames)
    return out


def contact_runs(flags: torch.Tensor) -> list[tuple[int, int]]:
    """``flags (T,)`` bool -> list of ``[start, stop)`` runs of True."""
    if flags.ndim != 1:
        raise ValueError(f"contact_runs: expected flags (T,), got {tuple(flags.shape)}")
    runs, start = [], None
    for i, f in enumerate(flags.bool().tolist() + [False]):
        if f and start is None:
            start = i
        elif not f and start is not None:
            runs.append((start, i))
            start = None
    return runs


def peak_acceleration(gpos: torch.Tensor, fps: float) -> float:
    """The largest joint acceleration (m/s²) of positions ``gpos (T, J, 3)``: second differences over all joints
    and frames (0 for fewer than 3 frames)."""
    if gpos.ndim != 3 or gpos.shape[-1] != 3:
        raise ValueError(f"peak_acceleration: expected positions (T, J, 3), got {tuple(gpos.shape)}")
    if gpos.shape[0] < 3:
        return 0.0
    p = gpos.double()
    return float(((p[2:] - 2 * p[1:-1] + p[:-2]).norm(dim=-1) * fps * fps).max())


@dataclass(frozen=True)
class FeetMeasures:
    """What :func:`feet_measures` reads of a result against its content (metres; accelerations m/s²)."""

    contacts: int  # the content's contact runs (heel and toe of both feet)
    drift_median: float  # per contact: the result's joint's largest distance over the ground (xz) from where it was at
    # the contact's start
    drift_worst: float
    jump_worst: float  # the largest single-frame move of a foot joint during a contact of the content
    floor_median: float  # per contact: |the result's foot joint height - the content's|, medians over the contact
    floor_worst: float
    peak_acc: float  # the result's, the content's
    peak_acc_content: float


def feet_measures(result: torch.Tensor, content: torch.Tensor, fps: float, spec: CanonicalSpec = CANONICAL,
                  floor: torch.Tensor | None = None, config: ContactConfig = ContactConfig()) -> FeetMeasures:
    """The result's feet against the content's contacts (:func:`contact_flags` of ``content``): ``result`` and
    ``content`` global positions ``(T, J, 3)``, frame for frame."""
    _check_positions(result, spec, "feet_measures")
    if content.shape != result.shape:
        raise ValueError(f"feet_measures: expected content {tuple(result.shape)}, got {tuple(content.shape)}")
    flags = contact_flags(content, fps, spec, floor, config)
    drift, jump, height = [], 0.0, []
    for k, j in enumerate(spec.feet):
        for s, e in contact_runs(flags[:, k]):
            p = result[s:e, j].double()
            drift.append(float((p - p[0])[:, [0, 2]].norm(dim=-1).max()))
            if e - s > 1:
                jump = max(jump, float((p[1:] - p[:-1]).norm(dim=-1).max()))
            height.append(abs(float(p[:, 1].median() - content[s:e, j, 1].double().median())))
    d, h = torch.tensor(drift or [0.0]), torch.tensor(height or [0.0])
    return FeetMeasures(len(drift), float(d.median()), float(d.max()), jump, float(h.median()), float(h.max()),
                        peak_acceleration(result, fps), peak_acceleration(content, fps))


def swing_clearance(gpos: torch.Tensor, fps: float, spec: CanonicalSpec = CANONICAL,
                    flags: torch.Tensor | None = None, floor: torch.Tensor | None = None,
                    config: ContactConfig = ContactConfig()) -> float | None:
    """How high the toes clear the floor in swing (metres): over each swing of a foot (the frames between two of its
    contacts, heel or toe), the toe's highest height above its floor; the median over the swings. ``gpos (T, J, 3)``;
    ``flags (T, 4)``: the contacts to read the swings from (default :func:`contact_flags` of ``gpos``). None where
    no foot leaves the floor and comes back (a clip done in place)."""
    _check_positions(gpos, spec, "swing_clearance")
    flags = contact_flags(gpos, fps, spec, floor, config) if flags is None else flags.bool()
    h = foot_heights(gpos, spec, floor)
    peaks = []
    for side in range(len(spec.feet) // 2):
        planted = flags[:, 2 * side] | flags[:, 2 * side + 1]
        runs = contact_runs(planted)
        for (_, e0), (s1, _) in pairwise(runs):
            peaks.append(float(h[e0:s1, 2 * side + 1].max()))
    return float(torch.tensor(peaks).median()) if peaks else None


def _slides_split(result: torch.Tensor, content: torch.Tensor, fps: float, spec: CanonicalSpec,
                  floor: torch.Tensor | None, config: ContactConfig, name: str) -> tuple[torch.Tensor, torch.Tensor]:
    """``(T - 1, 2)`` each: a foot of ``result`` sliding (:func:`motioncore.skating.skating_feet`), and the content's
    same foot in swing at both frames (no heel or toe contact)."""
    from motioncore.skating import skating_feet

    _check_positions(result, spec, name)
    if content.shape != result.shape:
        raise ValueError(f"{name}: expected content {tuple(result.shape)}, got {tuple(content.shape)}")
    flags = contact_flags(content, fps, spec, floor, config)
    swinging = ~(flags[:, 0::2] | flags[:, 1::2])  # (T, 2): left, right
    return skating_feet(result, fps, spec=spec), swinging[1:] & swinging[:-1]


def planted_slides(result: torch.Tensor, content: torch.Tensor, fps: float, spec: CanonicalSpec = CANONICAL,
                   floor: torch.Tensor | None = None, config: ContactConfig = ContactConfig()) -> float:
    """The share of frame transitions of ``result (T, J, 3)`` in which a foot reads as sliding
    (:func:`motioncore.skating.skating_feet`) where the content's (``content (T, J, 3)``, frame for frame) is planted
    at either frame (a heel or toe contact, :func:`contact_flags`): a planted foot sliding. 0 for fewer than 2
    frames."""
    if result.shape[0] < 2:
        return 0.0
    slide, swinging = _slides_split(result, content, fps, spec, floor, config, "planted_slides")
    return float((slide & ~swinging).any(1).float().mean())


def low_steps(result: torch.Tensor, content: torch.Tensor, fps: float, spec: CanonicalSpec = CANONICAL,
              floor: torch.Tensor | None = None, config: ContactConfig = ContactConfig()) -> float:
    """The share of frame transitions of ``result (T, J, 3)`` in which a foot reads as sliding
    (:func:`motioncore.skating.skating_feet`) while the content's (``content (T, J, 3)``, frame for frame) is in swing
    at both frames (no heel or toe contact, :func:`contact_flags`): a low step skimming the floor, not a planted foot
    sliding. 0 for fewer than 2 frames."""
    if result.shape[0] < 2:
        return 0.0
    slide, swinging = _slides_split(result, content, fps, spec, floor, config, "low_steps")
    return float((slide & swinging).any(1).float().mean())
