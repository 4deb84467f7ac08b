"""A canonical content motion styled a span of frames at a time: the one apply path for every length. A clip held
in memory is one span (:func:`stylize_motion`); a long BVH take is read, styled and written a span at a time, with
memory that does not grow with the take (:mod:`video2style.long_takes`, issue 25).

The diffusion windows run over the whole motion fed in order (:class:`transfer.apply.StyleStream`: the same starts,
batches and noise however it is fed, each window's crossfade finished across a span's end). Each span is then
guarded (:func:`transfer.apply.guard_features`), decoded with its stray limbs drawn back (:func:`transfer.apply.decoder`)
and its feet cleaned, seeing ``margin`` frames either side. The guards read time means and the encoder's reading
of what they see, so a span of a long take is guarded on its own: its posture, arm hold and content share are its
span's (5 minutes by default), not the whole take's."""
from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass

import torch

from mlcore.device import model_device
from motioncore.cleanup import cleanup_feet, relock_legs
from motioncore.feet import contact_flags, low_steps, peak_acceleration, planted_slides, swing_clearance
from motioncore.motion import Motion
from motioncore.representation import FEATURES, decode, encode, facing_angle
from motioncore.skating import motion_skating
from motioncore.skeleton import CANONICAL
from motioncore.smooth import limit_acceleration
from transfer.apply import (
    READ_FRAMES,
    StyleStream,
    decoder,
    guard_features,
    neutral_caption,
)


@dataclass
class StyledSpan:
    """Frames ``start..stop-1`` of a styled motion, finished, with the frames around them from ``lo`` on that the
    guards, the decode and the foot cleanup saw: the ``content`` and the ``result`` (feet cleaned) of those frames,
    and the foot-skating ratios of frames ``start..stop-1`` (``skating_before`` and ``skating_after`` the cleanup,
    ``skating_content``)."""

    start: int
    stop: int
    lo: int
    content: Motion
    result: Motion
    skating: dict


FEET_MODES = ("auto", "lock", "off")


def check_feet(feet: str) -> None:
    """``--feet``: auto, lock or off, else ``ValueError("feet: expected ...")``."""
    if feet not in FEET_MODES:
        raise ValueError(f"feet: expected one of {', '.join(FEET_MODES)}, got {feet!r}")


SPIKE_ROUNDS = 3  # spikes drawn out, then the planted legs solved again, at most this many times
SPIKE_LIMIT = 1.4  # a result's joints accelerate at most this many times as fast as the content's or the example's


@dataclass(frozen=True)
class ExampleFeet:
    """What the foot cleanup reads of a style example: its toes' swing clearance (metres,
    :func:`motioncore.feet.swing_clearance`; None where it never steps) and its peak joint acceleration (m/s²)."""

    swing: float | None = None
    peak_acc: float = 0.0


def example_feet(example: torch.Tensor | None) -> ExampleFeet:
    """:class:`ExampleFeet` of a style example's raw features ``(T', D)`` (None: no example)."""
    if example is None or example.shape[0] < 3:
        return ExampleFeet()
    motion = decode(example.float())
    gpos = motion.global_positions()
    return ExampleFeet(swing_clearance(gpos, motion.fps), peak_acceleration(gpos, motion.fps))


def _planted_slides(motion: Motion, ref: Motion, frames: slice) -> float:
    part, content = motion.slice(frames.start, frames.stop), ref.slice(frames.start, frames.stop)
    return planted_slides(part.global_positions(), content.global_positions(), part.fps)


def planted_legs(content: Motion, floor: torch.Tensor | None = None, spec=CANONICAL) -> tuple[torch.Tensor, torch.Tensor]:
    """Where the ``content``'s feet are planted (heel or toe, :func:`motioncore.feet.contact_flags`; ``floor``: a
    take's): ``(T, 2)`` bool, left and right foot, and ``(T, J)`` bool, the joints of those legs (hip to toes),
    which the foot cleanup solved."""
    flags = contact_flags(content.global_positions(), content.fps, spec, floor)
    legs = torch.stack([flags[:, 2 * side] | flags[:, 2 * side + 1] for side in range(len(spec.legs))], 1)
    out = torch.zeros(content.num_frames, spec.num_joints, dtype=torch.bool)
    for side, leg in enumerate(spec.legs):
        for j in (*leg, spec.feet[2 * side + 1]):
            out[:, j] = legs[:, side]
    return legs, out


def clean_feet(raw: Motion, ref: Motion, feet: str, floor: torch.Tensor | None, example: ExampleFeet,
               frames: slice, content_acc: float | None = None) -> tuple[Motion, dict]:
    """The last stage of one span of the apply path: ``raw`` (decoded; ``ref`` the content, the same frames) with no
    joint accelerating faster than :data:`SPIKE_LIMIT` times the content's (``content_acc``, a take's; default
    ``ref``'s own) or the ``example``'s peak (:func:`motioncore.smooth.limit_acceleration`; after the cleanup again,
    in up to :data:`SPIKE_ROUNDS` rounds, the planted legs held and solved again, :func:`motioncore.cleanup.relock_legs`),
    and its feet, as ``--feet`` says: cleaned against the content's
    contacts (:func:`motioncore.cleanup.cleanup_feet`, the example's swing clearance) with ``lock``; left as they
    are with ``off``; with ``auto`` cleaned unless that makes the span's own ``frames`` slide more where the content
    plants a foot than the decoded result did (:func:`motioncore.feet.planted_slides`; then left as they are: cleanup
    never makes planted feet slide more). Returns the motion and the sliding shares of ``frames``
    (``skating_before``: the decoded result's; ``skating_after``, ``skating_content``;
    :func:`motioncore.skating.motion_skating`), the share of them where a foot is low and fast while the content's
    is in swing (``skating_low_steps``: low steps, not slides; a cleaned foot put back on the floor may read so where
    the decoded one floated) and ``feet_cleaned`` (None with ``off``: no cleanup was asked for)."""
    check_feet(feet)
    before = motion_skating(raw.slice(frames.start, frames.stop))
    if content_acc is None:
        content_acc = peak_acceleration(ref.global_positions(), ref.fps)
    limit = SPIKE_LIMIT * max(content_acc, example.peak_acc)
    smooth = limit_acceleration(raw, limit) if limit > 0 else raw  # a still content without an example: no measure
    cleaned, used = smooth, False
    if feet != "off":
        # the legs' IK may add spikes of its own on a style far from the content: drawn out last
        cleaned = cleanup_feet(smooth, reference=ref, floor=floor, swing=example.swing)
        if limit > 0:  # the legs' IK may add spikes of its own on a style far from the content: drawn out last, the
            # planted legs solved again where the hips moved
            legs, frozen = planted_legs(ref, floor)
            for _ in range(SPIKE_ROUNDS):
                limited = limit_acceleration(cleaned, limit, frozen=frozen)
                if limited is cleaned:
                    break
                cleaned = relock_legs(limited, cleaned, legs)
            # what the planted legs' IK itself left (a knee near full reach flicking over a frame): drawn out with the
            # legs free, the last word, so no joint is left past the limit
            cleaned = limit_acceleration(cleaned, limit)
        used = True
        if feet == "auto" and _planted_slides(cleaned, ref, frames) > _planted_slides(raw, ref, frames):
            cleaned, used = smooth, False
    part, content = cleaned.slice(frames.start, frames.stop), ref.slice(frames.start, frames.stop)
    return cleaned, {"skating_before": before, "skating_after": motion_skating(part),
                     "skating_content": motion_skating(content), "feet_cleaned": used if feet != "off" else None,
                     "skating_low_steps": low_steps(part.global_positions(), content.global_positions(), part.fps)}


@torch.no_grad()
def stylize_spans(bundle, style, model, content: Callable[[int, int], Motion], n: int, strength: float = 0.5,
                  seed: int = 0, neutralize: str = "auto", floor: torch.Tensor | None = None, span: int | None = None,
                  margin: int = 0, report: dict | None = None, feet: str = "auto",
                  content_acc: float | None = None) -> Iterator[StyledSpan]:
    """Apply a loaded style (``style``: a :class:`transfer.style_file.Style`; ``model``: the prior with its adapters)
    to a canonical content motion of ``n`` frames, ``content(a, b)`` giving its frames ``a..b-1`` (asked for
    in order, a frame either side of a span for the features' velocities; the first 8 s again when the first
    span is shorter), with the models of ``bundle``
    (:class:`transfer.bundle.MethodBundle`): the result's spans of ``span`` frames (None: one span, the whole
    motion) in order, each guarded, decoded and cleaned with ``margin`` frames either side (see the module's
    docstring). ``floor (4,)``: the foot joints' lowest heights over the whole motion (the contact channels; None:
    each span's own). ``neutralize``: auto (only when the motion encoder reads the first span's start, 8 s, as a
    styled clip confidently), always or never. ``report`` receives ``detected`` and ``neutralized``, then with each
    span the smallest ``still_share``, ``arm_motion_share`` and ``content_share`` so far. ``feet``: auto, lock or off
    (:func:`clean_feet`; ``content_acc``: the content's peak joint acceleration over the whole motion, m/s², which
    the spike limit is a multiple of; None: each span's own). ``strength`` 0 gives the content itself, span by span (nothing read, styled or cleaned).
    On ``model``'s device (the bundle's models there too); the motions are on the CPU."""
    check_feet(feet)
    learned, config = style.configs()
    span = n if span is None else max(int(span), 2 * margin + 2)
    report = {} if report is None else report
    if strength == 0:  # the content unchanged (the README's promise): no model, guard or cleanup touches it
        report.update(detected=None, neutralized=False, swing_example=example_feet(style.example).swing)
        for a in range(0, n, span):
            b = min(n, a + span)
            part = content(a, b)
            skating = motion_skating(part)
            yield StyledSpan(a, b, a, part, part, {"skating_before": skating, "skating_after": skating,
                                                   "skating_content": skating, "feet_cleaned": None,
                                                   "skating_low_steps": 0.0})
        return
    example_read = example_feet(style.example)
    report["swing_example"] = example_read.swing
    device = model_device(model)
    content_buf, feats_buf, styled_buf = _Buffer(), _Buffer(), _Buffer()  # content; normalised content, styled
    shares: list[float] = []
    stream, state, c = None, None, 0  # state: the decode's start (frame, yaw, xz); c: the next frame to finish
    for a in range(0, n, span):
        b = min(n, a + span)
        e0, e1 = max(0, a - 1), min(n, b + 1)
        part = content(e0, e1)
        feats = bundle.normalize(encode(part, floor=floor))[a - e0:b - e0]
        if stream is None:
            neutral_text, detected = None, None
            if neutralize != "never":  # the reading is of the first 8 s (read_motion): a short first span's too
                head = feats if feats.shape[0] >= min(n, READ_FRAMES) else \
                    bundle.normalize(encode(content(0, min(n, READ_FRAMES + 40)), floor=floor))
                reading, neutral_text = neutral_caption(bundle.motion_encoder, bundle.text_encoder, head, neutralize)
                del head
                detected = reading.describe()
            report.update(detected=detected, neutralized=neutral_text is not None)
            stream = StyleStream(bundle, model, n, learned, config, strength, seed, neutral_text, shares=shares,
                                 gain=style.gain)
            p0 = part.global_positions()[:1].double()
            state = (0, float(facing_angle(p0)[0]), (float(p0[0, 0, 0]), float(p0[0, 0, 2])))
        content_buf.append(part.slice(a - e0, b - e0))
        del part
        x, styled = stream.feed(feats.to(device))
        feats_buf.append(x)
        styled_buf.append(styled)
        while c < n and styled_buf.end >= min(n, c + span + margin):
            d = min(n, c + span)
            lo, hi = max(0, c - margin), min(n, d + margin)
            g, yaw, xz = state
            if g != lo:
                raise RuntimeError(f"spans: the decode's start is frame {g}, expected {lo}")
            ref = content_buf.get(lo, hi)
            guarded: dict = {}
            out = guard_features(bundle, styled_buf.get(lo, hi), feats_buf.get(lo, hi), stream.config, strength,
                                 style.posture_shift, style.example, guarded, style.gain)
            if shares:
                report["still_share"] = min(shares)
            for key, value in guarded.items():
                report[key] = min(value, report.get(key, value))
            # in place where no later span reads these frames (the last): one copy of a clip's features at a time
            f_ext = bundle.denormalize(out.cpu(), inplace=d == n)
            raw = decoder(config, reference=ref, example=style.example)(f_ext, ref.fps, start_yaw=yaw, start_xz=xz)
            cleaned, skating = clean_feet(raw, ref, feet, floor, example_read, slice(c - lo, d - lo),
                                          content_acc)
            yield StyledSpan(c, d, lo, ref, cleaned, skating)
            c = d
            if c < n:
                nxt = max(0, d - margin)  # the next span's context starts here: the root's state there
                i = nxt - lo
                yaw = yaw + float(f_ext[:i, FEATURES.root_rvel][:, 0].double().sum())
                state = (nxt, yaw, (float(raw.lpos[i, 0, 0]), float(raw.lpos[i, 0, 2])))
                for buf in (content_buf, feats_buf, styled_buf):
                    buf.drop(nxt)


def stylize_motion(bundle, style, model, content_motion: Motion, strength: float = 0.5, seed: int = 0,
                   neutralize: str = "auto", feet: str = "auto") -> tuple[Motion, dict]:
    """Apply a loaded style (``style``: a :class:`transfer.style_file.Style`; ``model``: the prior with its adapters,
    :func:`transfer.style_file.style_model`) to a canonical content motion (canonical fps; ``T`` frames) with the
    models of ``bundle`` (:class:`transfer.bundle.MethodBundle`): the stylised canonical motion, ``T`` frames on the
    same path (:func:`stylize_spans`, one span). Stray limbs are drawn back (``limb_guard`` of the style's config,
    :func:`transfer.apply.guard_stray_limbs`), then the feet cleaned against the content
    (:func:`clean_feet`, as ``feet`` says: auto, lock or off).

    ``strength``: see :func:`transfer.style_config.strength_settings` (0.5: twice the learned change). ``neutralize``:
    auto (only when the motion encoder reads a styled clip confidently), always or never. Returns the result and
    what was decided (``detected``, ``neutralized``, ``content_share`` where the content keeper ran, ``still_share``
    where the difference mode ran) with the foot-skating ratios before and after cleanup and of
    the content itself, how much of the result's is low steps (``skating_low_steps``), whether the feet were cleaned
    (``feet_cleaned``, :func:`clean_feet`) and the toes' swing clearance, the example's and the result's
    (``swing_example``, ``swing_result``; :func:`motioncore.feet.swing_clearance`). Runs on ``model``'s device (the bundle's models there too); the motion and the result are
    on the CPU."""
    report: dict = {}
    (whole,) = stylize_spans(bundle, style, model, content_motion.slice, content_motion.num_frames, strength, seed,
                             neutralize, report=report, feet=feet)
    decided = {"detected": report.pop("detected"), "neutralized": report.pop("neutralized")}
    info = {**decided, **whole.skating, **report}
    info["swing_result"] = swing_clearance(whole.result.global_positions(), whole.result.fps)
    return whole.result, info


class _Buffer:
    """Frames of a motion from ``start`` to ``end``: tensors ``(k, D)`` or canonical motions, appended in order,
    dropped from the front."""

    def __init__(self):
        self.parts, self.start, self.end = [], 0, 0

    def append(self, x) -> None:
        k = x.num_frames if isinstance(x, Motion) else x.shape[0]
        if k:
            self.parts.append(x)
            self.end += k

    def get(self, lo: int, hi: int):
        if lo < self.start or hi > self.end:
            raise RuntimeError(f"spans: frames {lo}-{hi} asked of {self.start}-{self.end}")
        whole = self._joined()
        off = self.start
        return whole.slice(lo - off, hi - off) if isinstance(whole, Motion) else whole[lo - off:hi - off]

    def drop(self, before: int) -> None:
        if before <= self.start:
            return
        whole = self._joined()
        k = before - self.start
        if isinstance(whole, Motion):
            self.parts = [Motion(whole.skeleton, whole.lrot[k:].clone(), whole.lpos[k:].clone(), whole.fps)]
        else:
            self.parts = [whole[k:].clone()]
        self.start = before

    def _joined(self):
        if len(self.parts) > 1:
            p = self.parts
            self.parts = [Motion(p[0].skeleton, torch.cat([q.lrot for q in p]), torch.cat([q.lpos for q in p]), p[0].fps)
                          if isinstance(p[0], Motion) else torch.cat(p)]
        return self.parts[0]
