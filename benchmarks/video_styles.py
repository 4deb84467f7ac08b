"""Do the styles of real videos show on the demo walks? (issue 49, item 4)

    python -m benchmarks.video_styles [--videos ../shared/data/videos] [--styles-dir runs/video_styles] [--strength 0.5]

Each video (``*.mp4`` in ``--videos``) is learned as ``video2style learn`` learns it, with the defaults (style files
kept in ``--styles-dir`` and reused when present); each style is then applied as ``apply`` applies it to the demo's
walks (``samples/walk_prior.bvh``, ``samples/walk_turn_left_prior.bvh``). Printed per style and walk, from
:func:`evaluation.metrics.gait_measures`: the trunk's lean, the hands' swing, the step length and the cadence of
the walk (the content), of the result, and of the video's own lifted motion (the style example). A style *shows* on
a walk when, in at least one of the four, the result moved from the content towards the example by at least half
of what the example differs from the neutral walk (same sign, ``|result - content| >= 0.5 |example - content|``),
with the example differing by more than :data:`MIN_DIFFERENCE` of that measure (smaller differences are not a
style an animator can see). The cadence is left out where ``--tempo`` is off (the default: a result keeps its
content's timing, so its cadence cannot follow).
"""
from __future__ import annotations

import argparse
import math
from pathlib import Path

MEASURES = ("lean_deg", "arm_swing_cm", "step_cm", "cadence_spm")
MIN_DIFFERENCE = {"lean_deg": 2.0, "arm_swing_cm": 5.0, "step_cm": 5.0, "cadence_spm": 5.0}
ROOT = Path(__file__).resolve().parent.parent
WALKS = (ROOT / "samples" / "walk_prior.bvh", ROOT / "samples" / "walk_turn_left_prior.bvh")


def shows(content: dict, result: dict, example: dict, keys=MEASURES) -> list[str]:
    """The measures (of ``keys``) in which ``result`` moved from ``content`` towards ``example`` by at least half of
    the way, where the example differs visibly (:data:`MIN_DIFFERENCE`)."""
    out = []
    for k in keys:
        want = example[k] - content[k]
        got = result[k] - content[k]
        if math.isnan(want) or math.isnan(got) or abs(want) < MIN_DIFFERENCE[k]:
            continue
        if got * want > 0 and abs(got) >= 0.5 * abs(want):
            out.append(k)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--videos", type=Path, default=ROOT.parent / "shared" / "data" / "videos")
    ap.add_argument("--styles-dir", type=Path, default=Path("runs/video_styles"))
    ap.add_argument("--strength", type=float, default=0.5)
    ap.add_argument("--tempo", default="off", help="off (default) or auto, as apply's --tempo")
    args = ap.parse_args()

    from benchmarks.styles import learned_styles
    from evaluation.metrics import gait_measures
    from motioncore.representation import decode
    from motioncore.skeleton import CANONICAL
    from transfer.bundle import load_models
    from transfer.spans import stylize_motion
    from transfer.style_file import Style, style_model
    from transfer.tempo import resolve_tempo
    from video2style.pipeline import read_clip, warp_clip

    videos = sorted(args.videos.glob("*.mp4"))
    if not videos:
        raise SystemExit(f"{args.videos}: no .mp4 videos")
    m = load_models()
    walks = [read_clip(p) for p in WALKS]
    keys = MEASURES if args.tempo != "off" else MEASURES[:3]
    print(f"strength {args.strength}, --tempo {args.tempo}; lean deg, arm swing cm, step cm, cadence steps/min; "
          "content -> result (example)")
    shown = 0
    for video in videos:
        try:
            (path,) = learned_styles([video], args.styles_dir)
        except (ValueError, OSError) as e:  # a video the tool refuses is reported, the others go on
            print(f"{video.name}: not learned: {e}")
            continue
        style = Style.load(path)
        model = style_model(m.prior, style)
        example = decode(style.example, CANONICAL.fps)
        ex = gait_measures(example)
        for clip in walks:
            if args.tempo != "off":
                clip = warp_clip(clip, resolve_tempo(style, args.tempo))
            result, _ = stylize_motion(m, style, model, clip.canonical, args.strength)
            c, r = gait_measures(clip.canonical), gait_measures(result)
            visible = shows(c, r, ex, keys)
            shown += bool(visible)
            cells = "  ".join(f"{k.split('_')[0]} {c[k]:.1f} -> {r[k]:.1f} ({ex[k]:.1f})" for k in MEASURES)
            print(f"{video.stem:<32} {clip.path.stem:<22} {cells}  shows: {', '.join(visible) or 'nothing'}")
    print(f"{shown} of {len(videos) * len(walks)} style x walk pairs show the style in at least one measure")


if __name__ == "__main__":
    main()
