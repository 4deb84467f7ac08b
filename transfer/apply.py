"""Applying a learned style to normalised features of any length: what the motion encoder reads in a clip
(:func:`read_motion`, :func:`neutral_caption`), the windowed editing of normalised features (:class:`StyleStream`,
whole or a span at a time) and the guards on its result (:func:`guard_features`), both in
:func:`apply_style_features` (the one place evaluation styles features), and how features become a motion
(:func:`decoder`, the stray-limb guard). A canonical motion is styled in spans by :mod:`transfer.spans`, the one
apply path of apply, batch and Ray, for every length."""
from __future__ import annotations

import functools
from dataclasses import dataclass

import torch

from mlcore.captions import BANDAI2_CONTENTS, STYLES, caption
from mlcore.device import model_device
from mlcore.windows import WindowStream, crossfade_overlap, window_starts
from motioncore.cleanup import cleanup_feet
from motioncore.motion import Motion
from motioncore.representation import FEATURES, decode
from motioncore.skating import motion_skating
from transfer.edit import neutralize, stylize
from transfer.posture import (
    arm_gate,
    arm_motion_share,
    gate_arms,
    keep_arm_motion,
    match_posture,
    posture_between,
    posture_channels,
)
from transfer.style_config import ApplyConfig, LearnConfig, strength_settings, style_amount

# Thresholds of a confident reading, chosen on the val split (docs/archive/RESULTS-notebook.md#content-safety,
# "When apply neutralises first"): every
# Bandai val original has a top similarity >= 0.82 and P(content) >= 0.5 at the 5th percentile; foreign clips
# (fair1, Xia) reach at most 0.73 and 0.31; P(styled) >= 0.8 flags all styled val clips and no normal one.
CONFIDENT_SIMILARITY = 0.78
CONFIDENT_CONTENT = 0.4
CONFIDENT_STYLED = 0.8
ENCODER_TEMPERATURE = 0.07  # the motion encoder's contrastive temperature (EncoderTrainConfig)


@dataclass(frozen=True)
class Reading:
    """What the motion encoder reads in a clip: the nearest content and style captions and how sure it is."""

    content: str
    style: str
    p_content: float  # softmax mass of the content over the 70 (content, style) captions
    p_styled: float  # softmax mass of every style but normal
    similarity: float  # cosine similarity of the nearest caption
    top: tuple[tuple[str, float], ...]  # the three nearest captions and their similarities

    @property
    def confident(self) -> bool:
        """In the prior's world: a known content, recognised clearly (foreign clips are not)."""
        return self.similarity >= CONFIDENT_SIMILARITY and self.p_content >= CONFIDENT_CONTENT

    def should_neutralize(self, mode: str = "auto") -> bool:
        """``auto``: only a confident reading of a styled clip; ``always``/``never``."""
        if mode not in ("auto", "always", "never"):
            raise ValueError(f"neutralize: expected auto, always or never, got {mode!r}")
        if mode != "auto":
            return mode == "always"
        return self.confident and self.p_styled >= CONFIDENT_STYLED

    def describe(self) -> str:
        sure = "confident" if self.confident else "not confident: unlike the training clips"
        return (f"{self.content}/{self.style} (similarity {self.similarity:.2f}, P(content) {self.p_content:.2f}, "
                f"P(styled) {self.p_styled:.2f}; {sure})")


READ_FRAMES = 160  # the motion encoder reads at most this many frames (8 s) at once


def _caption_similarities(motion_encoder, text_encoder, xs: torch.Tensor) -> torch.Tensor:
    """Cosine similarities ``(N, C * S)`` of normalised motions ``xs (N, L, D)`` to every (content, style) caption,
    contents outer (:data:`BANDAI2_CONTENTS`, :data:`STYLES`); made on the CPU."""
    emb = text_encoder.encode([caption(c, s) for c in BANDAI2_CONTENTS for s in STYLES])
    with torch.no_grad():
        z = motion_encoder(xs.to(model_device(motion_encoder))).cpu()
    return z @ emb.T


def read_motion(motion_encoder, text_encoder, x: torch.Tensor) -> Reading:
    """The :class:`Reading` of a normalised motion ``(T, D)`` (its first 8 s) in the motion encoder's space
    (the encoder runs on its own device; the reading is made on the CPU)."""
    if x.ndim != 2 or x.shape[1] != FEATURES.dim:
        raise ValueError(f"read_motion: expected features (T, {FEATURES.dim}), got {tuple(x.shape)}")
    pairs = [(c, s) for c in BANDAI2_CONTENTS for s in STYLES]
    sims = _caption_similarities(motion_encoder, text_encoder, x[None, :READ_FRAMES])[0]
    p = torch.softmax(sims / ENCODER_TEMPERATURE, 0).reshape(len(BANDAI2_CONTENTS), len(STYLES))
    p_content, p_style = p.sum(1), p.sum(0)
    ci, si = int(p_content.argmax()), int(p_style.argmax())
    order = sims.argsort(descending=True).tolist()[:3]
    return Reading(BANDAI2_CONTENTS[ci], STYLES[si], float(p_content[ci]), float(1 - p_style[STYLES.index("normal")]),
                   float(sims.max()), tuple((caption(*pairs[i]), float(sims[i])) for i in order))


def content_probabilities(motion_encoder, text_encoder, x: torch.Tensor) -> torch.Tensor:
    """How surely the motion encoder reads each Bandai-2 content in normalised motion ``x (T, D)``: the softmax mass
    of its captions (all styles), averaged over windows of :data:`READ_FRAMES` covering the clip -> ``(C,)`` in
    :data:`BANDAI2_CONTENTS`'s order."""
    if x.ndim != 2 or x.shape[1] != FEATURES.dim:
        raise ValueError(f"content_probabilities: expected features (T, {FEATURES.dim}), got {tuple(x.shape)}")
    length = min(READ_FRAMES, x.shape[0])
    windows = torch.stack([x[s:s + length] for s in window_starts(x.shape[0], length, 0)])
    sims = _caption_similarities(motion_encoder, text_encoder, windows)
    p = torch.softmax(sims / ENCODER_TEMPERATURE, -1).reshape(len(windows), len(BANDAI2_CONTENTS), len(STYLES))
    return p.sum(-1).mean(0)


CONTENT_KEEP_SHARES = (0.875, 0.75, 0.625, 0.5, 0.375, 0.25)  # shares of the style's change tried in turn when the
# action is lost: eighths, so that the twice-learned default (issue 49) is not cut below what once gave


def keep_content(motion_encoder, text_encoder, out: torch.Tensor, content: torch.Tensor,
                 keep: float, top: bool = False) -> tuple[torch.Tensor, float]:
    """``out (T, D)``, stylised from ``content (T, D)`` (both normalised), with the style's change scaled down until the
    motion encoder still reads the content's action in it: when the content is read confidently
    (:meth:`Reading.confident`) as action ``c``, the largest share of the change in 1 and
    :data:`CONTENT_KEEP_SHARES` whose result keeps at least ``keep`` of the content's P(``c``)
    (:func:`content_probabilities`; with ``top``, or in which ``c`` is still the most likely action), else the
    smallest share. Returns the result and the share kept (1: unchanged;
    a clip the encoder does not read confidently, a foreign one, is left as it is)."""
    if out.shape != content.shape:
        raise ValueError(f"keep_content: expected out and content alike, got {tuple(out.shape)}, {tuple(content.shape)}")
    if not 0 < keep <= 1:
        raise ValueError(f"keep_content: expected keep in (0, 1], got {keep}")
    if not read_motion(motion_encoder, text_encoder, content).confident:
        return out, 1.0
    p_content = content_probabilities(motion_encoder, text_encoder, content)
    c = int(p_content.argmax())
    for share in (1.0, *CONTENT_KEEP_SHARES):
        result = out if share == 1.0 else content + share * (out - content)
        p = content_probabilities(motion_encoder, text_encoder, result)
        if p[c] >= keep * p_content[c] or (top and int(p.argmax()) == c):
            break
    return result, share


WINDOW_BATCH = 64  # windows denoised together: bounds memory on long clips (a 2-hour take is ~2,000 windows)


def neutral_caption(motion_encoder, text_encoder, x: torch.Tensor, mode: str = "auto") -> tuple[Reading, torch.Tensor | None]:
    """The one decision "redraw this clip neutral before styling it?": the :class:`Reading` of normalised
    content ``x (T, D)`` and, when :meth:`Reading.should_neutralize` says so, the embedding ``(1, E)`` of the
    neutral caption of what it reads (else None)."""
    from mlcore.captions import content_caption

    reading = read_motion(motion_encoder, text_encoder, x)
    if not reading.should_neutralize(mode):
        return reading, None
    return reading, text_encoder.encode([content_caption(reading.content)])


def _check_features(x: torch.Tensor) -> None:
    if x.ndim != 2 or x.shape[1] != FEATURES.dim:
        raise ValueError(f"expected features (T, {FEATURES.dim}), got {tuple(x.shape)}")


def _neutral_windows(prior, scheduler, n: int, text: torch.Tensor, learned: LearnConfig, generator: torch.Generator,
                     step: int | None, window: int, overlap: int) -> WindowStream:
    """:func:`transfer.edit.neutralize`'s windows over a motion of ``n`` frames under ``text (1, E)``."""
    return WindowStream(lambda p, i: neutralize(prior, scheduler, p, text.expand(p.shape[0], -1), learned, generator, step),
                        n, WINDOW_BATCH, window, overlap)


@torch.no_grad()
def neutralize_windows(prior, scheduler, x: torch.Tensor, text: torch.Tensor, learned: LearnConfig,
                       generator: torch.Generator, step: int | None = None, window: int = 80,
                       overlap: int | None = None) -> torch.Tensor:
    """:func:`transfer.edit.neutralize` of normalised features ``x (T, D)`` under ``text (1, E)`` (from ``step``,
    default G), in ``window``-frame windows crossfaded over ``overlap`` (default:
    :func:`mlcore.windows.crossfade_overlap`): the prior, trained on 80-frame windows, draws longer motion
    shuffling. A clip no longer than a window is drawn whole. ``x`` and ``text`` on the prior's device."""
    _check_features(x)
    overlap = crossfade_overlap(window) if overlap is None else overlap
    return _neutral_windows(prior, scheduler, x.shape[0], text, learned, generator, step, window, overlap).feed(x)


@torch.no_grad()
def neutralize_features(bundle, x: torch.Tensor, neutral_text: torch.Tensor, learned: LearnConfig, config: ApplyConfig,
                        seed: int = 0, window: int = 80, overlap: int | None = None) -> torch.Tensor:
    """The neutral version ``(T, D)`` of styled normalised content ``(T, D)``, same path; ``neutral_text (1, E)``;
    noised to ``config.neutralize_step`` and redrawn by the prior of ``bundle`` (:class:`transfer.bundle.MethodBundle`)
    as the style's pair was (``learned``), in windows (:func:`neutralize_windows`). Runs on the prior's device; the
    result is on ``x``'s."""
    device = model_device(bundle.prior)
    gen = torch.Generator().manual_seed(seed + 1)
    return neutralize_windows(bundle.prior, bundle.scheduler, x.to(device), neutral_text.to(device), learned, gen,
                              config.neutralize_step, window, overlap).to(x.device)


class StyleStream:
    """The windows of :func:`apply_style_features` over normalised content features of a motion of ``n`` frames, fed
    in order, a span at a time or whole: the neutral redraw first under ``neutral_text (1, E)`` when given
    (:func:`neutralize_features`, seed ``seed + 1``), then the style model's (:func:`transfer.edit.stylize`, seed
    ``seed``), each in ``window``-frame windows crossfaded over ``overlap`` (:class:`mlcore.windows.WindowStream`:
    the same windows, batches and noise however the motion is fed). ``config`` is the apply settings ``strength``
    sets (:func:`transfer.style_config.strength_settings`); the still-pose guard's share of each window goes to
    ``shares`` when a list is given. ``feed(x)`` (on ``model``'s device) returns ``(content, styled)``, the frames
    now finished: what they were styled from (neutralised where it was) and the result before
    :func:`guard_features`."""

    def __init__(self, bundle, model, n: int, learned: LearnConfig, config: ApplyConfig, strength: float | None = None,
                 seed: int = 0, neutral_text: torch.Tensor | None = None, window: int = 80, overlap: int | None = None,
                 shares: list | None = None, gain: float = 1.0):
        step, self.config = strength_settings(strength, learned, config, gain)
        overlap = crossfade_overlap(window) if overlap is None else overlap
        self.windows = []
        if neutral_text is not None and self.config.neutralize_step > 0:
            self.windows.append(_neutral_windows(bundle.prior, bundle.scheduler, n, neutral_text.to(model_device(model)),
                                                 learned, torch.Generator().manual_seed(seed + 1),
                                                 self.config.neutralize_step, window, overlap))
        gen = torch.Generator().manual_seed(seed)
        self.windows.append(WindowStream(lambda p, i: stylize(model, bundle.scheduler, p, learned, self.config, gen, step=step,
                                                              prior=bundle.prior, shares=shares), n, WINDOW_BATCH, window, overlap))
        self.pending = None  # content frames fed to the style's windows and not yet finished there

    @torch.no_grad()
    def feed(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        for w in self.windows[:-1]:
            x = w.feed(x)
        self.pending = x if self.pending is None else torch.cat([self.pending, x])
        styled = self.windows[-1].feed(x)
        content, self.pending = self.pending[:styled.shape[0]], self.pending[styled.shape[0]:]
        return content, styled


@torch.no_grad()
def apply_style_features(bundle, model, x: torch.Tensor, learned: LearnConfig, config: ApplyConfig,
                         strength: float | None = None, seed: int = 0, neutral_text: torch.Tensor | None = None,
                         window: int = 80, overlap: int | None = None, posture_shift: torch.Tensor | None = None,
                         example: torch.Tensor | None = None, report: dict | None = None,
                         gain: float = 1.0) -> torch.Tensor:
    """Stylise normalised content features ``(T, D)`` -> ``(T, D)`` with the style model ``model`` beside the prior
    of ``bundle`` (:class:`transfer.bundle.MethodBundle`): ``learned`` is the style's learning config, ``config`` its
    apply settings, which ``strength`` sets (:func:`transfer.style_config.strength_settings`; None: as learned).
    ``neutral_text (1, E)`` first neutralises a styled clip (:func:`neutralize_features`). In 80-frame windows
    crossfaded over ``overlap`` (default: :func:`mlcore.windows.crossfade_overlap`, 20; :class:`StyleStream`),
    then guarded (:func:`guard_features`: ``posture_shift``, ``example``). The smallest share of the difference's
    fast part that the still-pose guard kept over the windows (:func:`transfer.edit.keep_slow_when_still`) goes to
    ``report["still_share"]`` when a dict is given, with what the guards report. Runs on the models' device
    (``model`` and the prior on one); the result is on ``x``'s."""
    _check_features(x)
    still: list[float] | None = None if report is None else []
    stream = StyleStream(bundle, model, x.shape[0], learned, config, strength, seed, neutral_text, window, overlap, still,
                         gain)
    out_device = x.device
    x, out = stream.feed(x.to(model_device(model)))
    if report is not None and still:
        report["still_share"] = min(still)
    return guard_features(bundle, out, x, stream.config, strength, posture_shift, example, report, gain).to(out_device)


def guard_features(bundle, out: torch.Tensor, x: torch.Tensor, config: ApplyConfig, strength: float | None = None,
                   posture_shift: torch.Tensor | None = None, example: torch.Tensor | None = None,
                   report: dict | None = None, gain: float = 1.0) -> torch.Tensor:
    """The guards on ``out (T, D)``, stylised from ``x (T, D)`` (both normalised; ``x`` neutralised where it was;
    :class:`StyleStream`) by ``config`` (set by ``strength``): the whole of a clip's, or one span's of a long take
    (each span read on its own). ``posture_shift`` (a style's, :class:`transfer.style_file.Style`): with
    ``config.posture`` above 0, the result's time-mean change is drawn towards it (:func:`match_posture`; none when
    None), with ``config.posture_between`` no further than between the content's and the example's means
    (:func:`posture_between`). ``example`` (the style example's raw features ``(T', D)``): with ``config.arm_gate``
    above 0, an arm doing what the example's never does keeps the content's motion (:func:`arm_gate`,
    :func:`gate_arms`); with ``config.arm_travel`` above 0, the arms of a clip done in place keep its motion when the
    example travels (:func:`arm_motion_share`, :func:`keep_arm_motion`; the share to ``report["arm_motion_share"]``;
    a bundle without the features' normalisation, a test's toy one, has no ground speeds to read). With
    ``config.content_keep`` above 0 the change is scaled down where the motion encoder no longer reads the
    content's action (:func:`keep_content`; a bundle without a motion encoder, a test's toy one, has none to read
    with); the share kept goes to ``report["content_share"]`` when a dict is given."""
    amount = style_amount(strength, gain)  # times the example's posture change (transfer.style_config.style_amount)
    if posture_shift is not None and example is not None and config.posture_between and bundle.mean is not None:
        posture_shift = posture_between(posture_shift.to(x), x, bundle.normalize(example.to(x)), amount)
    if posture_shift is not None and config.posture > 0:
        out = match_posture(out, x, posture_shift, config.posture, amount)
    if example is not None and config.arm_gate > 0:
        out = gate_arms(out, x, arm_gate(bundle.denormalize(x), example.to(x.device), config.arm_gate))
    if example is not None and config.arm_travel > 0 and bundle.mean is not None:  # a toy bundle: no speeds to read
        share = arm_motion_share(bundle.denormalize(x), example.to(x.device), config.arm_travel)
        held = None
        if posture_shift is not None and config.posture > 0:
            held = posture_channels(posture_shift.to(out), out.shape[1], amount)
        out = keep_arm_motion(out, x, share, held)
        if report is not None:
            report["arm_motion_share"] = share
    if config.content_keep > 0 and bundle.motion_encoder is not None:
        out, share = keep_content(bundle.motion_encoder, bundle.text_encoder, out, x, config.content_keep,
                                  config.content_keep_top)
        if report is not None:
            report["content_share"] = share
    return out


def decoder(config: ApplyConfig, reference: Motion | None = None, example: torch.Tensor | None = None):
    """How a stylised result's features become a motion (``config.decode``): from the rotation channels
    (:func:`motioncore.representation.decode`), fitted to the position channels
    (:func:`motioncore.ik_fit.decode_via_positions`), or "guarded": the rotation channels except for a limb
    where the two disagree and the position fit is the smaller change from ``reference`` (the content the
    result was made from; :func:`motioncore.ik_fit.decode_guarded`). Each takes ``(feats, fps, start_yaw=,
    start_xz=)``. With ``reference`` and ``example`` (the style example's raw features ``(T', D)``) and
    ``config.limb_guard`` above 0, the decoded motion's stray limbs are then drawn back (:func:`guard_stray_limbs`)."""
    if config.decode == "rotations":
        decode_fn = decode
    elif config.decode == "guarded":
        from motioncore.ik_fit import decode_guarded

        decode_fn = functools.partial(decode_guarded, reference=reference)
    elif config.decode == "positions":
        from motioncore.ik_fit import decode_via_positions

        decode_fn = decode_via_positions
    else:
        raise ValueError(f"decode: expected 'rotations', 'guarded' or 'positions', got {config.decode!r}")
    if reference is None or example is None or config.limb_guard <= 0:
        return decode_fn

    def decode_guarding(feats: torch.Tensor, fps: float, **kwargs) -> Motion:
        return guard_stray_limbs(decode_fn(feats, fps, **kwargs), reference, example, config)

    return decode_guarding


def guard_stray_limbs(result: Motion, content: Motion, example: torch.Tensor, config: ApplyConfig) -> Motion:
    """A decoded canonical ``result`` of ``content`` (same frames) with each hand and foot whose time-mean place
    strays more than ``config.limb_guard`` metres off the segment from the content's place to the style
    ``example``'s (raw features ``(T', D)``) drawn back towards it (:func:`motioncore.limbs.guard_limbs`); the
    result itself when the guard is off (0) or no limb strays. Before the foot cleanup, which keeps contacts."""
    from motioncore.limbs import guard_limbs, limb_places, motion_limb_places

    if config.limb_guard <= 0:
        return result
    if result.num_frames != content.num_frames:
        raise ValueError(f"guard_stray_limbs: expected a content of {result.num_frames} frames, got {content.num_frames}")
    guarded, _ = guard_limbs(result, motion_limb_places(content), limb_places(example.float()), config.limb_guard,
                             swing_hands=config.guard_swing)
    return guarded


def cleanup_feet_measured(motion: Motion, content: Motion) -> tuple[Motion, dict]:
    """IK foot cleanup of a canonical ``motion`` against its ``content``'s contacts
    (:func:`motioncore.cleanup.cleanup_feet`); returns the motion and the foot-skating ratio before/after."""
    cleaned = cleanup_feet(motion, reference=content)
    return cleaned, {"skating_before": motion_skating(motion), "skating_after": motion_skating(cleaned)}
