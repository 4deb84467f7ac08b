"""The methods `evaluate` compares, by name: Park et al.'s stylizer, the identity baseline, and ours with
overrides of the style's configs (:func:`transfer.style_config.split_config`; experimental variants cited by
docs/archive/RESULTS-notebook.md; no two of them learn and apply alike). Plain data, so the command line can list them
without importing torch."""

VARIANTS = {
    "ours": {},
    "ours-calibrated": {"calibrate": True},  # the style's change times its calibrated gain (transfer.amount)
    # the content keeper asking for more of the action without its "still the most likely action" pass (issue 49;
    # without the pass alone: ours-keep05-s1045)
    "ours-keep-strict07": {"content_keep_top": False, "content_keep": 0.7},
    # the defaults before the unseen-style protocol (L_s on the style words, no directional loss, full difference);
    # rows dated before 2026-12-02 14:00 in the notebook ran every variant below on top of these
    # (docs/archive/RESULTS-notebook.md#styles-the-models-never-saw-issue-23)
    "ours-words": {"lambda_s": 0.1, "lambda_dir": 0.0, "style_scale": 1.0, "decode": "rotations"},
    "ours-no-pp": {"lambda_p": 0.0},
    "ours-no-pair": {"pair_generation": False},
    "ours-k150": {"transfer_noise_step": 150, "transfer_ddim_steps": 3},
    "ours-k600": {"transfer_noise_step": 600, "transfer_ddim_steps": 12},
    "ours-regen": {"apply_mode": "regenerate", "style_scale": 1.0},
    "ours-diff-no-pp-k600": {"apply_mode": "difference", "lambda_p": 0.0, "transfer_noise_step": 600, "transfer_ddim_steps": 12},
    "ours-guided": {"apply_mode": "regenerate", "style_scale": 2.0},
    "ours-diff-n600": {"apply_mode": "difference", "neutralize_step": 600},
    "ours-diff-n0": {"apply_mode": "difference", "neutralize_step": 0},
    "ours-diffg": {"apply_mode": "difference", "guided_difference": True},
    "ours-diffg-n600": {"apply_mode": "difference", "guided_difference": True, "neutralize_step": 600},
    "ours-diff-pp005": {"apply_mode": "difference", "lambda_p": 0.05},
    "ours-diff-ls05": {"apply_mode": "difference", "lambda_s": 0.5},
    "ours-diff-ls1": {"apply_mode": "difference", "lambda_s": 1.0},
    "ours-diff-s6": {"apply_mode": "difference", "delta_smoothing": 6.0},
    # style signals that need no style words (the unseen-style protocol's ablation)
    "ours-stat1": {"lambda_stat": 1.0},
    "ours-stat1m": {"lambda_stat": 1.0, "stat_std": False},
    "ours-stat1n": {"lambda_stat": 1.0, "stat_reference": "neutral"},
    "ours-stat1nm": {"lambda_stat": 1.0, "stat_reference": "neutral", "stat_std": False},
    "ours-stat3n": {"lambda_stat": 3.0, "stat_reference": "neutral"},
    "ours-dir3-ls0": {"lambda_dir": 3.0, "lambda_s": 0.0},
    "ours-dir03-ls0": {"lambda_dir": 0.3, "lambda_s": 0.0},
    "ours-dir10-ls0": {"lambda_dir": 10.0, "lambda_s": 0.0},
    "ours-pos": {"decode": "positions"},
    "ours-dir3-ls0-pos": {"lambda_dir": 3.0, "lambda_s": 0.0, "decode": "positions"},
    "ours-dir10-ls0-pos": {"lambda_dir": 10.0, "lambda_s": 0.0, "decode": "positions"},
    "ours-dir3-ls0-pp05": {"lambda_dir": 3.0, "lambda_s": 0.0, "lambda_p": 0.5},
    "ours-stat03n": {"lambda_stat": 0.3, "stat_reference": "neutral"},
    "ours-it150": {"iterations": 150},
    "ours-rotations": {"decode": "rotations", "style_scale": 0.9},  # the word-free default before the guarded decode
    "ours-g600": {"pair_noise_step": 600},  # the neutral pair drawn from step 600 instead of 950
    "ours-dir1-ls0-pp05": {"lambda_dir": 1.0, "lambda_s": 0.0, "lambda_p": 0.5},
    "ours-dir1-ls0-it80": {"lambda_dir": 1.0, "lambda_s": 0.0, "iterations": 80},
    "ours-dir1-ls0-s3": {"lambda_dir": 1.0, "lambda_s": 0.0, "delta_smoothing": 3.0},
    "ours-no-guard": {"limb_guard": 0.0},  # no stray-limb guard at apply (motioncore.limbs.guard_limbs)
    "ours-w4": {"rec_windows": 4},  # L_rec on four windows of the example per iteration
    "ours-w4-s11": {"rec_windows": 4, "style_scale": 1.1},
    # with the 34,000-step held-out prior (2026-12-04, before 21:00 on lambda_p 0.2 and lambda_dir 1): prior
    # preservation off, with more iterations or more direction; and the defaults of 2026-12-02 to 12-04
    "ours-no-pp-it80": {"lambda_p": 0.0, "iterations": 80},
    "ours-no-pp-dir4": {"lambda_p": 0.0, "lambda_dir": 4.0},
    "ours-pp02-dir1": {"lambda_p": 0.2, "lambda_dir": 1.0},
    # 2026-12-05: the direction of the statistics change (word-free, not the encoder's space)
    "ours-statdir1": {"lambda_stat_dir": 1.0},
    # ... and the example's posture change at apply (transfer.posture.match_posture; 0.5 the default since then)
    "ours-no-posture": {"posture": 0.0},
    "ours-posture03": {"posture": 0.3},
    "ours-posture07": {"posture": 0.7},
    "ours-posture1": {"posture": 1.0},
    # ... and an arm doing what the example's never does keeps the content's motion (transfer.posture.arm_gate)
    "ours-arm03": {"arm_gate": 0.3},
    "ours-arm04": {"arm_gate": 0.4},
    # ... and the style's change scaled down where the motion encoder no longer reads the content's action
    # (2026-12-05 09:00-12:00; the default since then: content_keep 0.5, content_keep_top, style_scale 1.045)
    "ours-keep05": {"content_keep": 0.5, "content_keep_top": False, "style_scale": 0.95},
    "ours-keep08": {"content_keep": 0.8, "content_keep_top": False, "style_scale": 0.95},
    "ours-keep05-s1045": {"content_keep_top": False},  # a result read first as the content's action may still be scaled
    "ours-no-keep": {"content_keep": 0.0, "style_scale": 0.95},  # the default before it
    # 2026-12-05 (11:50-14:50): the style's difference low-passed over time (a style model that collapsed onto a
    # still pose cancels the content's steps: the demo's feet;
    # docs/archive/RESULTS-notebook.md#a-style-models-still-pose-the-demos-feet-issue-23-item-5-issue-24s-walks-shuffle)
    "ours-s4": {"delta_smoothing": 4.0},
    "ours-s8": {"delta_smoothing": 8.0},
    "ours-no-still": {"still_guard": False},  # the default before the still-pose guard (transfer.edit.keep_slow_when_still)
    # 2026-12-05 (17:29-20:29): a travelling example's style on a clip done in place moves its arms only by the
    # example's posture (transfer.posture.arm_motion_share; the default since then: arm_travel 0.5)
    "ours-no-armtr": {"arm_travel": 0.0},  # the default before it
    "ours-no-pb": {"posture_between": False},  # the posture not bounded by the content's and the example's means (before)
    # ... and the neutral pair's body held where the example or neutral clips of its action hold it while learning
    # (transfer.posture.bound_pair; "ours-pairb" before it became the default)
    "ours-no-pairb": {"pair_between": False},
    # ... and the stray-limb guard swinging an arm at the shoulder instead of bending its elbow (motioncore.limbs.swing_limb;
    # "ours-swing" before it became the default)
    "ours-guard-ik": {"guard_swing": False},
    # 2026-12-06: the neutral pair of an example longer than the prior's 80-frame window drawn whole (before), not in
    # windows (transfer.learn._pair; docs/archive/RESULTS-notebook.md#the-neutral-pair-in-windows-issue-23)
    "ours-whole-pair": {"pair_windowed": False},
}
METHODS = ("identity", "park", "park-raw", *VARIANTS)
# older names that still work: Park et al.'s rows, and variants that came to equal another when the defaults changed
# (docs/archive/RESULTS-notebook.md names them in its earlier runs)
ALIASES = {
    "stgcn": "park",
    "stgcn-raw": "park-raw",
    "ours-no-ls": "ours",
    "ours-diff": "ours",
    "ours-dir1-ls0": "ours-pp02-dir1",
    "ours-dir2-ls0": "ours",
    "ours-diff-pp01": "ours",
    "ours-no-pp-dir2": "ours-no-pp",
    "ours-pp01-dir2": "ours",
    "ours-diff-no-pp": "ours-no-pp",
    "ours-diff-k600": "ours-k600",
    "ours-posture05": "ours",
    "ours-keep-top": "ours",
}


def method_names(names) -> list[str]:
    """``names`` with :data:`ALIASES` replaced by the names they stand for, each once, in order (unknown names kept)."""
    return list(dict.fromkeys(ALIASES.get(n, n) for n in names))
