"""The hyperparameters of learning and applying a style: a plain dataclass (no torch), saved in each style
file and read by ``--help`` without importing the models."""
from __future__ import annotations

from dataclasses import dataclass

MIN_ITERATIONS = 25  # fewer: a cruder style that changes the action more often (val split, docs/RESULTS.md)


@dataclass
class StyleConfig:
    pair_step: int = 950  # G
    pair_steps: int = 30  # DDIM steps from G to 0 for the neutral pair
    guidance: float = 2.5
    transfer_step: int = 300  # K
    transfer_steps: int = 6  # DDIM steps from K to 0 (K = 300 with 20 steps over 1000)
    rank: int = 8
    lr: float = 2e-3
    iterations: int = 40  # the budget (chosen on the val split, docs/RESULTS.md): same example + seed = same style
    max_seconds: float | None = None  # optional wall-clock cap on the whole learning; None = no cap
    lambda_s: float = 0.0  # L_s, the style words' text target (Hu et al. eq. 11): 0 by default, since for a style the
    # encoders never saw the words carry no motion meaning (docs/RESULTS.md, "Styles the models never saw")
    content_batch: int = 8
    window: int = 80
    rec_windows: int = 1  # windows of the example (with their pair's) per L_rec iteration, each with its own noise
    seed: int = 0
    pair_generation: bool = True  # False (ablation): fine-tune from the example itself instead of its neutral pair
    lambda_p: float = 0.2  # prior preservation on the content batch (not in Hu et al.; 0 = the paper; see docs/RESULTS.md)
    apply_mode: str = "difference"  # regenerate: the style model redraws the content from step K;
    # difference: content + scale * (style model - prior), both from the same noisy content (the prior's error cancels)
    style_scale: float = 0.95  # difference mode: the scale of the style's difference at --strength 0.5 (chosen on the
    # unseen-style val split); regenerate: guidance weight
    neutralize_step: int = 950  # apply: a styled content clip is noised this far and redrawn neutral first
    guided_difference: bool = False  # difference mode: the scale guides the style chain (x0 = P + w (S - P)) instead
    # of multiplying its final difference
    delta_smoothing: float = 0.0  # difference mode: Gaussian sigma (frames) of a temporal low-pass on the difference
    lambda_stat: float = 0.0  # word-free: the style's change on content shifts feature statistics as the example
    # differs from its pair (transfer.style_losses.statistics_loss)
    stat_std: bool = True  # the statistics loss matches log standard deviations too, not only means
    stat_reference: str = "pair"  # what the example is compared with for that shift: its neutral pair, or
    # "neutral": the content source's neutral clips of the example's caption (the pair when it has none)
    decode: str = "guarded"  # apply: the result's rotations from its rotation channels ("rotations"), fitted to its
    # joint-position channels ("positions": a style's difference is linear there; in 6D rotations a large one swings
    # a limb), or "guarded": rotations except for a limb whose two channel sets disagree (motioncore.ik_fit)
    lambda_dir: float = 1.0  # word-free: the change in the motion encoder's space points as example - pair does
    limb_guard: float = 0.08  # apply: metres; a hand or foot whose time-mean place (hips' facing frame) lies further than
    # this off the segment from the content's place to the example's is drawn back by IK, softly, never left past 1.5x
    # (motioncore.limbs.guard_limbs); 0: off (the ablation)
