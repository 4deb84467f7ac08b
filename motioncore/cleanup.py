"""Foot cleanup (issue 50): lock the content's contacts, solve the legs with analytic two-bone IK, add nothing.

Contacts come from a reference motion (the content clip the result is aligned with, time-warped where the result
is): heel and toe of each foot, with hysteresis (:func:`motioncore.feet.contact_flags`). Each heel contact holds the
result's ankle at one place (its mean over the contact, at the content's ankle height: the content's floor); each
toe contact where the heel is up (toe-off) holds the toes so, the ankle following them with the foot's own pitch.
The correction each locked frame needs eases out of a contact and into the next across the swing between them
(smoothstep, over at most :attr:`FeetConfig.bridge` frames each side), so locking adds no jump or spike of its own.
The hips stay where the style put them (the style's posture; :attr:`FeetConfig.lower_hips` lowers them where a
planted foot is out of reach, off by default: it read as much less of the style). A planted foot is the content's
planted foot and its roll, turned and moved over the ground to where the result's foot is, each joint held through
its own contact (:attr:`FeetConfig.plant` "style" keeps the foot's own orientation instead, the heel or the toes
held as above); elsewhere each foot keeps its global orientation, the correction eased out. Each leg
is solved so the ankle reaches its target with the knee bending in its own plane, straightening softly near full
reach (:attr:`FeetConfig.reach`: never hyper-extended, no snap). A foot whose kept pitch would put its toes
through the floor is lifted until they touch it; a swing lower than the style example's own toe clearance is
raised to it (``swing``), never a swing lowered.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from itertools import pairwise

import torch

from motioncore import quat
from motioncore.feet import ContactConfig, contact_flags, contact_runs, foot_heights
from motioncore.kinematics import fk, rest_positions
from motioncore.motion import Motion
from motioncore.skeleton import CANONICAL, CanonicalSpec

__all__ = ["FeetConfig", "cleanup_feet", "contact_runs", "locked_offsets", "two_bone_ik"]


@dataclass(frozen=True)
class FeetConfig:
    """The foot cleanup's settings (:func:`cleanup_feet`)."""

    contacts: ContactConfig = field(default_factory=ContactConfig)
    bridge: int = 8  # frames a contact's correction eases out (and the next one's in) over, at most, each side
    reach: float = 0.985  # the leg straightens softly beyond this share of its length (two_bone_ik)
    stretch: float = 0.995  # the hips are lowered where a planted foot's target lies further than this share
    step: float = 0.10  # metres the content's toe travels in a swing for it to count as a step (swing clearance)
    max_lift: float = 0.04  # metres a swing is raised by at most towards the example's clearance
    max_turn: float = 1.0  # radians a planted foot is turned by at most towards the content's planted foot
    # how a planted foot is placed: "content", the content's planted foot and its roll, turned and moved to where the
    # result's foot is (no jump, on the content's floor); "style", its own pitch kept (the heel held where the content's
    # heel is planted, the toes where only its toes are, the ankle following with the foot's own pitch: on the Bandai-2
    # held-out val protocol it read 1 point more of the style, with feet jumping up to 9 cm;
    # docs/archive/RESULTS-notebook.md#session-of-2026-12-0708-22490105-clean-feet-and-smooth-limbs-issue-50)
    plant: str = "content"
    # lower the hips where a planted foot is out of the leg's reach (off by default: on the same protocol it read as
    # much less of the style, SRA 69.6 -> 52.6 %; a style whose hips float leaves its feet short of the floor)
    lower_hips: bool = False


def _ease(x: torch.Tensor) -> torch.Tensor:
    return x * x * (3 - 2 * x)


def locked_offsets(delta: torch.Tensor, locked: torch.Tensor, bridge: int) -> torch.Tensor:
    """``delta (T, C)`` wherever ``locked (T,)``, eased across the frames between: from one locked run's last value to
    the next run's first across a gap of up to ``2 * bridge`` frames, else out to 0 over ``bridge`` frames and in
    again; before the first run and after the last the same, or held where the motion ends sooner. Smoothstep: the result's velocity changes gradually, so the correction adds no spike."""
    if delta.ndim != 2 or locked.shape != delta.shape[:1]:
        raise ValueError(f"locked_offsets: expected delta (T, C) and locked (T,), got {tuple(delta.shape)}, "
                         f"{tuple(locked.shape)}")
    t = delta.shape[0]
    out = torch.zeros_like(delta)
    runs = contact_runs(locked.bool())
    for s, e in runs:
        out[s:e] = delta[s:e]
    bridge = max(1, int(bridge))

    def ramp(a: int, b: int, v0: torch.Tensor, v1: torch.Tensor) -> None:  # frames a..b-1 between v0 (at a-1) and v1 (at b)
        if b <= a:
            return
        x = torch.arange(1, b - a + 1, dtype=delta.dtype) / (b - a + 1)
        out[a:b] = v0 + (v1 - v0) * _ease(x)[:, None]

    zero = delta.new_zeros(delta.shape[1])
    if not runs:
        return out
    s0 = runs[0][0]
    if s0 < bridge:  # no room to ease in before the motion starts: the correction holds from its first frame
        out[:s0] = delta[s0]
    else:
        ramp(s0 - bridge, s0, zero, delta[s0])
    for (_, e0), (s1, _) in pairwise(runs):
        if s1 - e0 <= 2 * bridge:
            ramp(e0, s1, delta[e0 - 1], delta[s1])
        else:
            ramp(e0, e0 + bridge, delta[e0 - 1], zero)
            ramp(s1 - bridge, s1, zero, delta[s1])
    e = runs[-1][1]
    if t - e < bridge:
        out[e:] = delta[e - 1]
    else:
        ramp(e, e + bridge, delta[e - 1], zero)
    return out


def eased_targets(free: torch.Tensor, held: torch.Tensor, locked: torch.Tensor, bridge: int) -> torch.Tensor:
    """Targets ``(T, C)``: ``held (T, C)`` wherever ``locked (T,)``, ``free (T, C)`` (the motion's own path) moved by the
    held frames' corrections eased across the frames between (:func:`locked_offsets`), and next to each locked run
    drawn onto its held place so that the path comes to rest there and leaves from rest (over ``bridge`` frames, half
    a short gap at most): a foot the motion swings fast into a contact is slowed into it, not stopped at once."""
    if free.shape != held.shape or free.ndim != 2 or locked.shape != free.shape[:1]:
        raise ValueError(f"eased_targets: expected free and held (T, C) and locked (T,), got {tuple(free.shape)}, "
                         f"{tuple(held.shape)}, {tuple(locked.shape)}")
    t = free.shape[0]
    runs = contact_runs(locked.bool())
    if not runs:
        return free.clone()
    locked = locked.bool()
    offset = locked_offsets(held - free, locked, bridge)
    near = torch.zeros_like(free)  # the nearest locked run's held place, and how much it pulls
    w = torch.zeros(t, dtype=free.dtype)
    edges = [(None, runs[0][0])] + [(e, s) for (_, e), (s, _) in pairwise(runs)] + [(runs[-1][1], None)]
    for e0, s1 in edges:
        gap = (s1 if s1 is not None else t) - (e0 if e0 is not None else 0)
        k = min(bridge, gap // 2) if e0 is not None and s1 is not None else min(bridge, gap)
        for j in range(1, k + 1):
            x = float(_ease(torch.tensor(1.0 - j / (k + 1))))
            if e0 is not None:
                near[e0 + j - 1], w[e0 + j - 1] = held[e0 - 1], x
            if s1 is not None:
                near[s1 - j], w[s1 - j] = held[s1], x
    offset = (1 - w)[:, None] * offset + w[:, None] * (near - free)
    offset[locked] = (held - free)[locked]
    return free + offset


def two_bone_ik(grot: torch.Tensor, gpos: torch.Tensor, lrot: torch.Tensor, parents, hip: int, knee: int, ankle: int,
                target: torch.Tensor, reach: float | None = None) -> torch.Tensor:
    """New local rotations ``(T, J, 4)`` so the ``ankle`` reaches ``target (T, 3)``; the foot keeps its global rotation
    (``grot``, ``gpos (T, J, 3)``: the motion's global rotations and positions, ``lrot (T, J, 4)`` its local ones). The
    knee bends in its current plane. ``reach`` (a share of the leg's length, below 1): beyond it (or beyond the leg's
    own extension, where the motion has it straighter) the leg straightens softly, approaching full length without
    reaching it (no hyper-extended knee, no snap); None: straight up to full length."""
    h, k, a = gpos[:, hip], gpos[:, knee], gpos[:, ankle]
    l1 = (k - h).norm(dim=-1, keepdim=True)
    l2 = (a - k).norm(dim=-1, keepdim=True)
    to_t = target - h
    d = to_t.norm(dim=-1, keepdim=True)
    full = l1 + l2
    if reach is not None:  # softly from this share of the leg's length, or from as straight as the motion has it
        soft = torch.maximum(reach * full, (a - h).norm(dim=-1, keepdim=True).clamp(max=full - 2e-4))
        span = (full - soft).clamp_min(1e-6)
        d = torch.where(d > soft, soft + span * (1 - torch.exp(-(d - soft) / span)), d)
    d = d.clamp(min=(l1 - l2).abs() + 1e-4, max=full - 1e-4)
    u = torch.nn.functional.normalize(to_t, dim=-1)
    bend = (k - h) - ((k - h) * torch.nn.functional.normalize(a - h, dim=-1)).sum(-1, keepdim=True) * torch.nn.functional.normalize(a - h, dim=-1)
    pole = bend - (bend * u).sum(-1, keepdim=True) * u
    fallback = quat.mul_vec(grot[:, hip], torch.tensor([0.0, 0.0, 1.0]).expand_as(pole))  # knee forward
    fallback = fallback - (fallback * u).sum(-1, keepdim=True) * u
    if reach is not None:  # a leg nearly straight bends towards the front rather than flipping with its last few mm
        pole = pole + 0.01 * torch.nn.functional.normalize(fallback, dim=-1)
    pole = torch.where(pole.norm(dim=-1, keepdim=True) < 1e-5, fallback, pole)
    pole = torch.nn.functional.normalize(pole, dim=-1)
    x = (l1**2 - l2**2 + d**2) / (2 * d)
    y = (l1**2 - x**2).clamp_min(0).sqrt()
    knee_new = h + x * u + y * pole
    ankle_new = h + d * u

    swing_hip = quat.between(k - h, knee_new - h)
    g_hip = quat.mul(swing_hip, grot[:, hip])
    shank = quat.mul_vec(swing_hip, a - k)
    g_knee = quat.mul(quat.between(shank, ankle_new - knee_new), quat.mul(swing_hip, grot[:, knee]))
    out = lrot.clone()
    out[:, hip] = quat.mul(quat.inv(grot[:, parents[hip]]), g_hip)
    out[:, knee] = quat.mul(quat.inv(g_hip), g_knee)
    out[:, ankle] = quat.mul(quat.inv(g_knee), grot[:, ankle])
    return out


def _swing_lift(toe_h: torch.Tensor, ref_toe: torch.Tensor, planted: torch.Tensor, clearance: float,
                step: float, most: float) -> torch.Tensor:
    """``(T,)`` metres to raise a foot by so each swing (between two runs of ``planted (T,)``) in which the content's
    toe ``ref_toe (T, 3)`` travels at least ``step`` clears the floor by ``clearance`` at its highest (``toe_h (T,)``:
    the result's toe height above its floor), by ``most`` at most: a sine-squared bump over the swing, zero where it
    clears already."""
    lift = torch.zeros_like(toe_h)
    runs = contact_runs(planted)
    for (_, e0), (s1, _) in pairwise(runs):
        if s1 <= e0:
            continue
        travel = float((ref_toe[s1, [0, 2]] - ref_toe[e0 - 1, [0, 2]]).norm())
        short = min(most, clearance - float(toe_h[e0:s1].max()))
        if travel < step or short <= 0:
            continue
        x = torch.arange(1, s1 - e0 + 1, dtype=toe_h.dtype) / (s1 - e0 + 1)
        lift[e0:s1] = short * torch.sin(math.pi * x) ** 2 / float((torch.sin(math.pi * x) ** 2).max())
    return lift


def _plant_targets(ref_heel: torch.Tensor, ref_toe: torch.Tensor, heel: torch.Tensor, toe: torch.Tensor,
                   heel_on: torch.Tensor, toe_on: torch.Tensor, yaw_fallback: torch.Tensor, s: int,
                   e: int) -> tuple[torch.Tensor, torch.Tensor]:
    """Heel and toe targets ``(e - s, 3)`` over one planted run ``s..e-1`` of a foot: the content's foot (``ref_heel``,
    ``ref_toe (T, 3)``) at its own heights, turned about the vertical and moved over the ground to sit where the
    result's foot (``heel``, ``toe (T, 3)``) is on average over the run; a joint in contact (``heel_on``, ``toe_on (T,)``)
    held at one place over the ground through each of its contacts, the other joint of the foot placed about it as the
    content's is. ``yaw_fallback (T,)``: the turn to use where either foot points nearly straight down."""
    c_dir, r_dir = (ref_toe[s:e] - ref_heel[s:e]).mean(0), (toe[s:e] - heel[s:e]).mean(0)
    if float(c_dir[[0, 2]].norm()) > 0.03 and float(r_dir[[0, 2]].norm()) > 0.03:
        turn = math.atan2(float(r_dir[0]), float(r_dir[2])) - math.atan2(float(c_dir[0]), float(c_dir[2]))
    else:
        turn = float(yaw_fallback[s:e].mean())
    q = quat.from_yaw(torch.tensor([turn])).expand(e - s, 4)
    ground = ref_heel.new_tensor([1.0, 0.0, 1.0])
    c0, r0 = ref_heel[s:e].mean(0) * ground, heel[s:e].mean(0) * ground
    h, t = (quat.mul_vec(q, p[s:e] - c0) + r0 for p in (ref_heel, ref_toe))
    rel = t - h  # the content's foot, turned
    for p, on in ((h, heel_on[s:e]), (t, toe_on[s:e])):
        for a, b in contact_runs(on):
            p[a:b, [0, 2]] = p[a:b, [0, 2]].mean(0)
    h_on, t_on = heel_on[s:e, None], toe_on[s:e, None]
    h = torch.where(h_on | ~t_on, h, t - rel)  # a heel up about toes held, toes about a heel held
    t = torch.where(t_on | ~h_on, t, h + rel)
    return h, t


def cleanup_feet(motion: Motion, reference: Motion | None = None, spec: CanonicalSpec = CANONICAL,
                 floor: torch.Tensor | None = None, config: FeetConfig = FeetConfig(),
                 swing: float | None = None) -> Motion:
    """Lock the feet of a canonical ``motion`` during the contacts of ``reference`` (default: itself; the same
    frames), as the module's docstring says. ``floor (4,)``: the foot joints' lowest heights over a take
    (:func:`motioncore.feet.contact_flags`; default: ``reference``'s own). ``swing``: the style example's toe
    clearance in swing (metres, :func:`motioncore.feet.swing_clearance`): a step of the content that the result swings
    lower is raised to it (None: swings as they are)."""
    from motioncore.representation import facing_angle

    if motion.skeleton.names != spec.skeleton.names:
        raise ValueError("cleanup_feet: expected a motion on the canonical skeleton")
    ref = reference if reference is not None else motion
    if ref.num_frames != motion.num_frames:
        raise ValueError(f"cleanup_feet: expected a reference of {motion.num_frames} frames, got {ref.num_frames}")
    ref_gpos = ref.global_positions()
    flags = contact_flags(ref_gpos, ref.fps, spec, floor, config.contacts)  # (T, 4): Foot_L, Toes_L, Foot_R, Toes_R
    rest = rest_positions(spec.skeleton.offsets, spec.skeleton.parents)
    feet = list(spec.feet)
    ankle_floor = float(rest[feet[0], 1] - rest[feet, 1].min())
    toe_floor = min(0.0, float(ref_gpos[:, [feet[1], feet[3]], 1].min()))  # a content's lower floor holds
    grot, gpos = fk(motion.lrot, motion.lpos, spec.skeleton.parents)
    d = facing_angle(gpos, spec) - facing_angle(ref_gpos, spec)
    turn = torch.remainder(d + math.pi, 2 * math.pi) - math.pi
    legs = []  # per leg: the ankle's target and the foot's turn
    for side, (_hip, _knee, ankle) in enumerate(spec.legs):
        toe = feet[2 * side + 1]
        a, o = gpos[:, ankle], gpos[:, toe]
        planted = flags[:, 2 * side] | flags[:, 2 * side + 1]
        heel_at, toe_at = a.clone(), o.clone()
        for s, e in contact_runs(planted):  # the content's foot, placed where the result's is
            heel_at[s:e], toe_at[s:e] = _plant_targets(ref_gpos[:, ankle], ref_gpos[:, toe], a, o, flags[:, 2 * side],
                                                        flags[:, 2 * side + 1], turn, s, e)
        # the foot turned so its toes point at their target where planted, eased out across the swing
        ident = quat.identity(a.shape[0])
        turn_foot = quat.between(o - a, toe_at - heel_at)
        turn_foot = torch.where(turn_foot[:, :1] < 0, -turn_foot, turn_foot)
        angle = quat.angle(turn_foot)
        share = (config.max_turn / angle.clamp_min(1e-6)).clamp(max=1.0)
        turn_foot = quat.slerp(ident, turn_foot, share)  # a foot the style points far off is turned only part way
        if config.plant == "style":  # the style's own foot: the heel held, or the toes held and the foot's own pitch
            turn_foot = ident
            heel, tip = flags[:, 2 * side], flags[:, 2 * side + 1]
            heel_at = a.clone()
            for s, e in contact_runs(tip):
                held = o[s:e].mean(0).expand(e - s, 3).clone()
                held[:, 1] = ref_gpos[s:e, toe, 1]
                heel_at[s:e] = held - (o[s:e] - a[s:e])
            for s, e in contact_runs(heel):
                held = a[s:e].mean(0).expand(e - s, 3).clone()
                held[:, 1] = ref_gpos[s:e, ankle, 1]
                heel_at[s:e] = held
        turn_foot = quat.normalize(ident + locked_offsets(turn_foot - ident, planted, config.bridge))
        foot = quat.mul_vec(turn_foot, o - a)  # the toes about the ankle, turned
        target = eased_targets(a, heel_at, planted, config.bridge)
        if swing is not None:
            toe_h = foot_heights(gpos, spec, floor)[:, 2 * side + 1] + (target + foot - o)[:, 1]
            target[:, 1] += _swing_lift(toe_h, ref_gpos[:, toe], planted, swing, config.step,
                                         config.max_lift)
        # never through the floor: the ankle above its rest height, the toes (as the foot is turned) above the floor
        target[:, 1] = target[:, 1].clamp_min(ankle_floor)
        target[:, 1] += (toe_floor - (target[:, 1] + foot[:, 1])).clamp_min(0.0)
        legs.append((target, turn_foot))
    lpos = motion.lpos
    drop = _hips_drop(gpos, [t for t, _ in legs], spec, config) if config.lower_hips else None
    if drop is not None and float(drop.max()) > 0:
        lpos = lpos.clone()
        lpos[:, 0, 1] -= drop
        grot, gpos = fk(motion.lrot, lpos, spec.skeleton.parents)
    lrot = motion.lrot
    for (hip, knee, ankle), (target, turn_foot) in zip(spec.legs, legs):
        turned = grot.clone()
        turned[:, ankle] = quat.mul(turn_foot, grot[:, ankle])
        lrot = two_bone_ik(turned, gpos, lrot, spec.skeleton.parents, hip, knee, ankle, target, config.reach)
    return Motion(motion.skeleton, lrot, lpos, motion.fps)


def _hips_drop(gpos: torch.Tensor, targets: list[torch.Tensor], spec: CanonicalSpec, config: FeetConfig) -> torch.Tensor:
    """``(T,)`` metres to lower the hips by so every leg reaches its ankle target (``targets``: ``(T, 3)`` per leg of
    ``spec.legs``) within :attr:`FeetConfig.stretch` of its length (or its own extension, where straighter): the least drop per frame, spread smoothly over
    :attr:`FeetConfig.bridge` frames either side (a running maximum, then a running mean: never less than needed)."""
    need = torch.zeros(gpos.shape[0], dtype=gpos.dtype)
    for (hip, knee, ankle), target in zip(spec.legs, targets):
        full = float((gpos[0, knee] - gpos[0, hip]).norm() + (gpos[0, ankle] - gpos[0, knee]).norm())
        own = (gpos[:, ankle] - gpos[:, hip]).norm(dim=-1).clamp(max=full - 2e-4)
        cap = torch.maximum(torch.full_like(own, config.stretch * full), own)  # as straight as the motion has it
        rel = gpos[:, hip] - target
        flat = torch.minimum(rel[:, [0, 2]].norm(dim=-1), cap)
        need = torch.maximum(need, (rel[:, 1] - (cap ** 2 - flat ** 2).sqrt()).clamp_min(0.0))
    if float(need.max()) <= 0:
        return need
    r = max(1, int(config.bridge))
    padded = torch.nn.functional.pad(need[None, None], (r, r), mode="replicate")[0]
    peak = torch.nn.functional.max_pool1d(padded, 2 * r + 1, stride=1)
    padded = torch.nn.functional.pad(peak[None], (r, r), mode="replicate")[0]
    return torch.nn.functional.avg_pool1d(padded, 2 * r + 1, stride=1)[0]


def relock_legs(motion: Motion, locked: Motion, planted: torch.Tensor, spec: CanonicalSpec = CANONICAL,
                config: FeetConfig = FeetConfig()) -> Motion:
    """``motion`` (a small change of ``locked``, e.g. spikes drawn out of it; the same frames) with each leg solved
    again, at the frames its foot is ``planted (T, 2)`` (left, right), so that its ankle and foot are where
    ``locked`` has them: a change to the hips or spine moves no planted foot."""
    if locked.num_frames != motion.num_frames or planted.shape != (motion.num_frames, len(spec.legs)):
        raise ValueError(f"relock_legs: expected locked of {motion.num_frames} frames and planted "
                         f"({motion.num_frames}, {len(spec.legs)}), got {locked.num_frames} and {tuple(planted.shape)}")
    if not bool(planted.any()):
        return motion
    g_lock, p_lock = fk(locked.lrot, locked.lpos, spec.skeleton.parents)
    lrot = motion.lrot
    for side, (hip, knee, ankle) in enumerate(spec.legs):
        on = planted[:, side].bool()
        if not bool(on.any()):
            continue
        grot, gpos = fk(lrot, motion.lpos, spec.skeleton.parents)
        target = torch.where(on[:, None], p_lock[:, ankle], gpos[:, ankle])
        turned = grot.clone()
        turned[:, ankle] = torch.where(on[:, None], g_lock[:, ankle], grot[:, ankle])
        lrot = two_bone_ik(turned, gpos, lrot, spec.skeleton.parents, hip, knee, ankle, target, config.reach)
    return Motion(motion.skeleton, lrot, motion.lpos, motion.fps)
