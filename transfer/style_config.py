"""The hyperparameters of a style, in two plain dataclasses (no torch; ``--help`` reads them without importing
the models): :class:`LearnConfig`, what learning uses (the noise levels and step counts it learns at are reused
when the style is applied), and :class:`ApplyConfig`, what only applying uses. A style file keeps both in one JSON
object, ``config`` (:func:`config_dict`, :func:`split_config`); :data:`CONFIG_RANGES` holds each field's range,
checked for the command line's options and for a style file alike (:func:`check_config_value`). ``--strength``
becomes apply settings in one place, :func:`strength_settings`, which checks it (:func:`check_strength`)."""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields, replace

MIN_ITERATIONS = 25  # fewer: a cruder style that changes the action more often (val split,
# docs/archive/RESULTS-notebook.md#deterministic-learning)
MAX_RANK = 64
MAX_ITERATIONS = 10_000  # about 10 hours of learning on a 2-core CPU at 3.7 s per iteration


@dataclass
class LearnConfig:
    """How a style is learned (Hu et al. 2024 §3.2-3.5; ``transfer.learn.learn_style``)."""

    pair_noise_step: int = 950  # G: the noise step the neutral pair is drawn from
    pair_ddim_steps: int = 30  # the number of DDIM steps from G to 0 for the neutral pair
    guidance: float = 2.5
    transfer_noise_step: int = 300  # K: the noise step the content is edited from
    transfer_ddim_steps: int = 6  # the number of DDIM steps from K to 0 (K = 300 with 20 steps over 1000)
    rank: int = 8
    lr: float = 2e-3
    iterations: int = 40  # the budget: same example + seed = same style (chosen on the val split,
    # docs/archive/RESULTS-notebook.md#deterministic-learning)
    max_seconds: float | None = None  # optional wall-clock cap on the whole learning; None = no cap
    lambda_s: float = 0.0  # L_s, the style words' text target (Hu et al. eq. 11): 0 by default, since for a style the
    # encoders never saw the words carry no motion meaning
    # (docs/archive/RESULTS-notebook.md#styles-the-models-never-saw-issue-23)
    content_batch: int = 8
    window: int = 80
    rec_windows: int = 1  # windows of the example (with their pair's) per L_rec iteration, each with its own noise
    seed: int = 0
    pair_generation: bool = True  # False (ablation): fine-tune from the example itself instead of its neutral pair
    lambda_p: float = 0.1  # prior preservation on the content batch (not in Hu et al.; 0 = the paper; 0.1 with
    # lambda_dir 2 chosen on both protocols' val splits,
    # docs/archive/RESULTS-notebook.md#the-unseen-style-protocol-on-the-34000-step-held-out-prior-issue-23-2026-12-04)
    lambda_stat: float = 0.0  # word-free: the style's change on content shifts feature statistics as the example
    # differs from its pair (transfer.style_losses.statistics_loss)
    stat_std: bool = True  # the statistics loss matches log standard deviations too, not only means
    stat_reference: str = "pair"  # what the example is compared with for that shift: its neutral pair, or
    # "neutral": the content source's neutral clips of the example's caption (the pair when it has none)
    lambda_dir: float = 2.0  # word-free: the change in the motion encoder's space points as example - pair does
    lambda_stat_dir: float = 0.0  # word-free: the change of the content's body-channel statistics points as the
    # example's against its pair does (transfer.style_losses.statistics_direction_loss)
    pair_between: bool = True  # the pair's body channels held (time-means) where the example or the content source's
    # neutral clips of its action hold them (transfer.posture.bound_pair): a tilt the prior drew is not learned (chosen
    # on the val splits of both protocols,
    # docs/archive/RESULTS-notebook.md#a-neutral-pair-held-where-neutral-clips-hold-the-body-issue-23)
    pair_windowed: bool = True  # an example longer than ``window`` gets its pair drawn in ``window``-frame windows
    # crossfaded over a quarter of one, as apply draws: the prior, trained on 80-frame windows, draws longer motion
    # shuffling (docs/archive/RESULTS-notebook.md#the-neutral-pair-in-windows-issue-23);
    # False: drawn whole, as before 2026-12-06
    calibrate: bool = False  # after learning, the gain that makes results on neutral clips of other actions differ from
    # their content as much as the example differs from its pair (transfer.amount; learn --calibrate). Off by default:
    # on the val split and the dev styles it shows more style but reads the action less often than the targets allow
    # (dev actions 82 %, target 85; docs/results.md#calibrated-amount-opt-in)


@dataclass
class ApplyConfig:
    """How a learned style is applied (``transfer.apply``); learning never reads these. A style file holds the
    values it was learned with; ``--strength`` sets ``style_scale`` at apply (:func:`strength_settings`)."""

    apply_mode: str = "difference"  # regenerate: the style model redraws the content from step K;
    # difference: content + scale * (style model - prior), both from the same noisy content (the prior's error cancels)
    style_scale: float = 1.045  # difference mode: the scale of the style's difference at --strength 0.5 (chosen on the
    # val splits of both protocols with content_keep 0.5; 0.95 before,
    # docs/archive/RESULTS-notebook.md#a-content-keeper-at-apply-issue-23-2026-12-05-09001200); regenerate: guidance weight
    neutralize_step: int = 950  # apply: a styled content clip is noised this far and redrawn neutral first
    guided_difference: bool = False  # difference mode: the scale guides the style chain (x0 = P + w (S - P)) instead
    # of multiplying its final difference
    delta_smoothing: float = 0.0  # difference mode: Gaussian sigma (frames) of a temporal low-pass on the difference
    decode: str = "guarded"  # apply: the result's rotations from its rotation channels ("rotations"), fitted to its
    # joint-position channels ("positions": a style's difference is linear there; in 6D rotations a large one swings
    # a limb), or "guarded": rotations except for a limb whose two channel sets disagree (motioncore.ik_fit)
    limb_guard: float = 0.08  # apply: metres; a hand or foot whose time-mean place (hips' facing frame) lies further than
    # this off the segment from the content's place to the example's is drawn back by IK, softly, never left past 1.5x
    # (motioncore.limbs.guard_limbs); 0: off (the ablation)
    posture: float = 0.5  # apply: 0-1, how far the result's time-mean change of each body channel is drawn from the
    # style model's towards the example's change against its neutral pair (transfer.posture.match_posture; 0.5 chosen
    # on the unseen-style protocol's val split,
    # docs/archive/RESULTS-notebook.md#posture-where-the-example-holds-its-body-carried-at-apply-issue-23-2026-12-05);
    # style files without the change: none
    posture_between: bool = True  # apply: the posture takes each channel's time-mean no further than where the content
    # and the example hold it (transfer.posture.posture_between: a neutral pair drawn tilted would tilt the result;
    # chosen on the val splits of both protocols,
    # docs/archive/RESULTS-notebook.md#a-posture-between-the-contents-and-the-examples-issue-23)
    arm_gate: float = 0.0  # apply: metres; an arm whose hand is further than this from every place the example's hand
    # takes keeps the content's motion, easing over ARM_GATE_WIDTH (transfer.posture.arm_gate); 0: off
    arm_travel: float = 0.5  # apply: when a travelling example's style is applied to a clip that travels less than this
    # share of its ground speed, the arms keep the content's motion and are held where the example holds them against
    # its pair, in proportion below it (transfer.posture.arm_motion_share; 0.5 chosen on the val splits of both protocols,
    # docs/archive/RESULTS-notebook.md#where-the-arm-actions-content-went-continued); 0: off
    content_keep: float = 0.5  # apply: 0-1; the style's change is scaled down (3/4, 1/2, 1/4) until the motion encoder
    # still reads the content's action with at least this share of its certainty on the content (transfer.apply.keep_content;
    # 0.5 chosen on the val splits, docs/archive/RESULTS-notebook.md#a-content-keeper-at-apply-issue-23-2026-12-05-09001200);
    # 0: off
    content_keep_top: bool = True  # apply: the content keeper also lets pass a result whose most likely action is still
    # the content's (a styled walk read less surely, but first, as a walk keeps all of the style)
    still_guard: bool = True  # difference mode: where the style model redraws the content nearly without movement (it
    # collapsed onto a still pose), only the slow part of its difference is kept (transfer.edit.keep_slow_when_still)
    guard_swing: bool = True  # apply: the stray-limb guard moves a hand by swinging its arm at the shoulder (the elbow and
    # wrist keep their angles: a wave's elbow is what makes it a wave) instead of two-bone IK (motioncore.limbs.swing_limb;
    # chosen on the val splits of both protocols,
    # docs/archive/RESULTS-notebook.md#the-stray-limb-guard-swings-an-arm-at-the-shoulder-issue-23)


# config field -> (type, low, high): numbers outside are refused; in a style file's order (the fields as they were
# before the config was split in two, so files written since keep the same JSON)
CONFIG_RANGES = {
    "pair_noise_step": (int, 1, 999), "pair_ddim_steps": (int, 1, 100), "guidance": (float, 0.0, 20.0),
    "transfer_noise_step": (int, 1, 999), "transfer_ddim_steps": (int, 1, 50), "rank": (int, 1, MAX_RANK),
    "lr": (float, 0.0, 1.0), "iterations": (int, 1, MAX_ITERATIONS), "max_seconds": (float, 0.0, 7 * 86400.0),
    "lambda_s": (float, 0.0, 100.0), "content_batch": (int, 1, 64), "window": (int, 8, 400), "rec_windows": (int, 1, 16),
    "seed": (int, -(2**63), 2**63 - 1), "pair_generation": (bool, None, None), "lambda_p": (float, 0.0, 100.0),
    "apply_mode": (str, ("regenerate", "difference"), None), "style_scale": (float, 0.0, 20.0),
    "neutralize_step": (int, 0, 999), "guided_difference": (bool, None, None), "delta_smoothing": (float, 0.0, 100.0),
    "lambda_stat": (float, 0.0, 100.0), "stat_std": (bool, None, None), "stat_reference": (str, ("pair", "neutral"), None),
    "decode": (str, ("rotations", "guarded", "positions"), None), "lambda_dir": (float, 0.0, 100.0),
    "limb_guard": (float, 0.0, 1.0), "lambda_stat_dir": (float, 0.0, 100.0), "posture": (float, 0.0, 1.0),
    "arm_gate": (float, 0.0, 2.0), "content_keep": (float, 0.0, 1.0),
    "content_keep_top": (bool, None, None), "still_guard": (bool, None, None), "arm_travel": (float, 0.0, 10.0), "posture_between": (bool, None, None),
    "pair_between": (bool, None, None), "guard_swing": (bool, None, None), "pair_windowed": (bool, None, None),
    "calibrate": (bool, None, None),
}
# learning fields a style file written before they existed was learned without (their default since differs):
# read so from a file that lacks them (:meth:`transfer.style_file.Style.configs`)
LEARNED_WITHOUT = {"pair_between": False, "pair_windowed": False, "calibrate": False}
# the names style files written before 2026-12 give these fields (a noise step and a number of DDIM steps differed
# by one letter): read under the new names (:func:`current_names`), written under the new ones
OLD_NAMES = {"pair_step": "pair_noise_step", "pair_steps": "pair_ddim_steps",
             "transfer_step": "transfer_noise_step", "transfer_steps": "transfer_ddim_steps"}
LEARN_FIELDS = tuple(f.name for f in fields(LearnConfig))
APPLY_FIELDS = tuple(f.name for f in fields(ApplyConfig))


def config_dict(learn: LearnConfig, apply: ApplyConfig) -> dict:
    """A style file's ``config`` object: both configs' fields, in :data:`CONFIG_RANGES`'s order."""
    values = {**asdict(learn), **asdict(apply)}
    return {name: values[name] for name in CONFIG_RANGES}


def current_names(config: dict) -> dict:
    """A style file's ``config`` object with the :data:`OLD_NAMES` of fields renamed, in place of order; the same
    dict when it has none. A field under both its names: ValueError."""
    if not any(k in OLD_NAMES for k in config):
        return config
    both = [k for k in OLD_NAMES if k in config and OLD_NAMES[k] in config]
    if both:
        raise ValueError(f"config: {both[0]} and {OLD_NAMES[both[0]]} are the same field, given twice")
    return {OLD_NAMES.get(k, k): v for k, v in config.items()}


def split_config(config: dict) -> tuple[LearnConfig, ApplyConfig]:
    """A ``config`` object (a style file's, or overrides of the defaults) -> ``(LearnConfig, ApplyConfig)``; fields it
    lacks take today's defaults. An unknown field raises TypeError, as a dataclass does."""
    unknown = [k for k in config if k not in LEARN_FIELDS and k not in APPLY_FIELDS]
    if unknown:
        raise TypeError(f"unknown config field(s) {', '.join(map(str, unknown))}")
    return (LearnConfig(**{k: v for k, v in config.items() if k in LEARN_FIELDS}),
            ApplyConfig(**{k: v for k, v in config.items() if k in APPLY_FIELDS}))


def check_value(name: str, value, kind, low, high) -> None:
    """``value`` of type ``kind`` within ``[low, high]`` (a str: one of ``low``); ValueError naming ``name``."""
    if value is None and name.endswith("max_seconds"):  # no time cap
        return
    if kind is bool:
        if not isinstance(value, bool):
            raise ValueError(f"{name}: expected true or false, got {type(value).__name__}")
        return
    if kind is str:
        if value not in low:
            raise ValueError(f"{name}: expected one of {', '.join(low)}, got {str(value)[:40]!r}")
        return
    if isinstance(value, bool) or not isinstance(value, (int, float)) or (kind is int and not isinstance(value, int)):
        raise ValueError(f"{name}: expected {'an integer' if kind is int else 'a number'}, got {type(value).__name__}")
    if not math.isfinite(value) or not low <= value <= high:
        raise ValueError(f"{name}: expected a number from {low} to {high}, got {value}")


def check_config_value(name: str, value) -> None:
    """``value`` for the config field ``name`` within the range a style file is held to; ValueError
    (``expected ..., got ...``, without the field's name) otherwise. The CLI checks its options with it."""
    kind, low, high = CONFIG_RANGES[name]
    try:
        check_value(name, value, kind, low, high)
    except ValueError as e:
        raise ValueError(str(e).removeprefix(f"{name}: ")) from None


MAX_STEP = 999


def check_strength(strength: float) -> None:
    """``--strength`` from 0 (the content unchanged) to 1: ValueError ``strength: expected ...`` otherwise."""
    if not 0 <= strength <= 1:
        raise ValueError(f"strength: expected a number from 0 to 1, got {strength:g}")


def strength_to_step(strength: float) -> int:
    """The regenerate mode's noise step K for ``--strength`` in (0, 1] (0.5 -> K = 300, the paper's)."""
    check_strength(strength)
    if strength == 0:
        raise ValueError("strength: the regenerate mode redraws the content from a noise step; expected a number "
                         "above 0, got 0")
    return max(1, min(MAX_STEP, round(600 * strength)))


DEFAULT_STRENGTH = 0.5  # --strength's default; None (the style's own setting) reads as it
STRENGTH_AMOUNT = 2.0  # how many times the learned change and the example's posture change are applied at --strength
# 0.5: twice what one application of the learned difference gives (before 2026-12-08: once, chosen on the three Bandai-2
# held-out styles the unseen protocol tests; twice chosen on the union of the five unseen dev styles and that
# protocol's val split, docs/results.md#the-default-amount-issue-49)


def style_amount(strength: float | None, gain: float = 1.0) -> float:
    """How many times the difference mode applies the learned change (and the posture its example's change) at
    ``--strength`` (None: :data:`DEFAULT_STRENGTH`): ``2 * strength * STRENGTH_AMOUNT * gain``, so 0 gives the
    content, 0.5 :data:`STRENGTH_AMOUNT` times ``gain`` (the style's calibrated amount, :mod:`transfer.amount`), and
    1 twice that."""
    strength = DEFAULT_STRENGTH if strength is None else strength
    check_strength(strength)
    return 2.0 * strength * STRENGTH_AMOUNT * gain


def strength_settings(strength: float | None, learn: LearnConfig, apply: ApplyConfig,
                      gain: float = 1.0) -> tuple[int, ApplyConfig]:
    """``--strength`` -> ``(K, apply config)`` for ``transfer.edit.stylize`` under the style's ``apply_mode``; the
    one place a strength becomes settings. None: the default strength (:data:`DEFAULT_STRENGTH`; regenerate: the
    style's own K and scale). ``gain``: the style's calibrated amount (:mod:`transfer.amount`), multiplying the
    difference mode's scale.

    regenerate: K = 600 * strength (0.5 -> 300, the paper's), the scale from the style's config;
    difference: K from the style's config, scale = :func:`style_amount` * ``style_scale`` (0 -> the content
    unchanged, 0.5 -> :data:`STRENGTH_AMOUNT` times the learned difference, 1 -> twice that).
    """
    if apply.apply_mode == "difference":
        return learn.transfer_noise_step, replace(apply, style_scale=style_amount(strength, gain) * apply.style_scale)
    if strength is None:
        return learn.transfer_noise_step, apply
    return strength_to_step(strength), apply
