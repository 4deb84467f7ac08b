"""Stray limbs: does a style put a hand or foot where neither the content nor the example holds it?

    python benchmarks/stray_limbs.py --style S.v2s [S2.v2s ...] --content A.bvh [B.bvh ...] [--strength 0.5]
    python benchmarks/stray_limbs.py --learn EXAMPLE.mp4 [EXAMPLE.bvh ...] --content ... [--styles-dir DIR]
    python benchmarks/stray_limbs.py ... --limb-guard 0     # without the apply-time guard (the ablation)
    python benchmarks/stray_limbs.py ... --guard-swing off  # the guard bends arms by two-bone IK (before)

For each style x content clip, the result is made as ``apply`` makes it (:func:`transfer.spans.stylize_motion`),
and for each hand and foot its time-mean place in the hips' facing frame (canonical body) is compared with the
segment from the content's place to the example's (:func:`evaluation.metrics.limb_stray`, after the
style's stray-limb guard: ``ApplyConfig.limb_guard``). Prints the stray of
each limb in cm and the worst per result; target: under 15 cm. ``--learn`` learns each example with the
defaults first (style files kept in ``--styles-dir``, reused when present).
"""
from __future__ import annotations

import argparse
from pathlib import Path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--style", nargs="*", type=Path, default=[], help="learned style files")
    ap.add_argument("--learn", nargs="*", type=Path, default=[], help="examples (video or BVH) to learn with the defaults")
    ap.add_argument("--styles-dir", type=Path, default=Path("runs/stray_styles"))
    ap.add_argument("--content", nargs="+", type=Path, required=True, help="content BVH clips")
    ap.add_argument("--strength", type=float, default=0.5)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--decode", choices=["rotations", "guarded", "positions"],
                    help="apply with this decoding instead of the style's own (ApplyConfig.decode)")
    ap.add_argument("--limb-guard", type=float,
                    help="apply with this stray-limb guard (metres; 0: off) instead of the style's own (ApplyConfig.limb_guard)")
    ap.add_argument("--guard-swing", choices=["on", "off"],
                    help="the guard swings an arm at the shoulder (on) or bends it by IK (off) instead of the style's own "
                         "choice (ApplyConfig.guard_swing)")
    args = ap.parse_args()

    import torch

    from benchmarks.styles import learned_styles
    from evaluation.metrics import LIMBS, limb_stray
    from motioncore.representation import encode
    from transfer.bundle import load_models
    from transfer.spans import stylize_motion
    from transfer.style_file import Style, style_model
    from video2style.pipeline import read_clip

    styles = list(args.style) + learned_styles(args.learn, args.styles_dir)
    m = load_models()
    clips = [read_clip(p) for p in args.content]
    print(f"strength {args.strength}; stray in cm ({', '.join(LIMBS)}), worst; target < 15 cm")
    worst_all = []
    for sp in styles:
        style = Style.load(sp)
        if args.decode:
            style.meta["config"]["decode"] = args.decode
        if args.limb_guard is not None:
            style.meta["config"]["limb_guard"] = args.limb_guard
        if args.guard_swing is not None:
            style.meta["config"]["guard_swing"] = args.guard_swing == "on"
        model = style_model(m.prior, style)
        example = style.example.float()
        for clip in clips:
            result, _ = stylize_motion(m, style, model, clip.canonical, args.strength, args.seed)
            stray = 100 * limb_stray(encode(clip.canonical), example, encode(result))
            worst = float(stray.max())
            worst_all.append(worst)
            cells = " ".join(f"{v:5.1f}" for v in stray.tolist())
            print(f"{sp.stem:>24} x {clip.path.stem:<34} {cells}   worst {worst:5.1f} ({LIMBS[int(stray.argmax())]})")
    if worst_all:
        t = torch.tensor(worst_all)
        print(f"results {len(t)}: worst stray median {t.median():.1f} cm, max {t.max():.1f} cm, "
              f"{int((t < 15).sum())} of {len(t)} under 15 cm")


if __name__ == "__main__":
    main()
