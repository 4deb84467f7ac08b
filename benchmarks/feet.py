"""Clean feet and smooth limbs (issue 50): what apply's foot cleanup leaves, per style x content clip.

    python -m benchmarks.feet --style S.v2s [S2.v2s ...] --content A.bvh [B.bvh ...] [--feet auto|lock|off]
    python -m benchmarks.feet --learn EXAMPLE.mp4 [EXAMPLE.bvh ...] --content ... [--styles-dir DIR]

Each result is made as ``apply`` makes it (:func:`transfer.spans.stylize_motion`, strength ``--strength``), then
read against its content's contacts (:func:`motioncore.feet.contact_flags`, heel and toe; :func:`motioncore.feet.feet_measures`):

- drift: per contact, the foot joint's largest distance over the ground from where it was at the contact's start (median, worst;
  target: median <= 1 cm, worst <= 3 cm);
- acc: the result's peak joint acceleration over the larger of the content's and the style example's (target <= 1.5);
- jump: the largest single-frame move of a foot joint in a contact of the content (target <= 1.5 cm);
- floor: per contact, |the result's foot joint height - the content's| (median, worst; target <= 0.5 cm);
- swing: the result's toe clearance in swing (:func:`motioncore.feet.swing_clearance`) and the example's;
- slide: the sliding share (:func:`motioncore.skating.motion_skating`) before and after the cleanup, the content's
  (target: after <= before on every clip).

``--strength0`` also checks that ``--strength 0`` returns each content as apply writes it (the largest joint distance
on the clip's own skeleton, target <= 0.1 mm). ``--learn`` learns each example with the defaults first (style files
kept in ``--styles-dir``, reused when present).
"""
from __future__ import annotations

import argparse
from pathlib import Path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--style", nargs="*", type=Path, default=[], help="learned style files")
    ap.add_argument("--learn", nargs="*", type=Path, default=[], help="examples (video or BVH) to learn with the defaults")
    ap.add_argument("--styles-dir", type=Path, default=Path("runs/feet_styles"))
    ap.add_argument("--content", nargs="+", type=Path, required=True, help="content BVH clips")
    ap.add_argument("--strength", type=float, default=0.5)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--feet", choices=["auto", "lock", "off"], default="auto", help="apply's --feet")
    ap.add_argument("--strength0", action="store_true", help="also check --strength 0 on each content clip")
    args = ap.parse_args()

    import torch

    from benchmarks.styles import learned_styles
    from motioncore.feet import feet_measures, peak_acceleration, swing_clearance
    from motioncore.representation import decode
    from transfer.bundle import load_models
    from transfer.spans import stylize_motion
    from transfer.style_file import Style, style_model
    from video2style.pipeline import read_clip, write_result

    styles = list(args.style) + learned_styles(args.learn, args.styles_dir)
    m = load_models()
    clips = [read_clip(p) for p in args.content]
    print(f"strength {args.strength}, --feet {args.feet}, seed {args.seed}; cm; acc = result's peak / max(content's, "
          "example's); swing = result's toe clearance / example's; slide % before -> after (the content's; of it low "
          "steps, the content's foot in swing; 'left': --feet auto left the feet as styled)")
    head = f"{'style':>26} x {'content':<30} {'drift med/worst':>15} {'acc':>17} {'jump':>5} {'floor med/worst':>15} " \
           f"{'swing res/ex':>12} {'slide % b->a (c; low)':>22}"
    print(head)
    rows = []
    for sp in styles:
        style = Style.load(sp)
        model = style_model(m.prior, style)
        ex = decode(style.example.float())
        ex_pos = ex.global_positions()
        ex_acc = peak_acceleration(ex_pos, ex.fps)
        ex_swing = swing_clearance(ex_pos, ex.fps)
        for clip in clips:
            result, info = stylize_motion(m, style, model, clip.canonical, args.strength, args.seed, feet=args.feet)
            r_pos, c_pos = result.global_positions(), clip.canonical.global_positions()
            fm = feet_measures(r_pos, c_pos, result.fps)
            swing = swing_clearance(r_pos, result.fps)
            acc = fm.peak_acc / max(fm.peak_acc_content, ex_acc)
            row = dict(style=sp.stem, content=clip.path.stem, drift_median=fm.drift_median, drift_worst=fm.drift_worst,
                       acc_ratio=acc, acc=fm.peak_acc, acc_content=fm.peak_acc_content, acc_example=ex_acc,
                       jump=fm.jump_worst, floor_median=fm.floor_median, floor_worst=fm.floor_worst, swing=swing,
                       swing_example=ex_swing, before=info["skating_before"], after=info["skating_after"],
                       content_slide=info["skating_content"], low_steps=info.get("skating_low_steps", 0.0),
                       cleaned=info.get("feet_cleaned", True))
            row["jump_content"] = feet_measures(c_pos, c_pos, result.fps).jump_worst  # the content's own, same contacts
            rows.append(row)
            sw = "-" if swing is None else f"{100 * swing:.1f}"
            sx = "-" if ex_swing is None else f"{100 * ex_swing:.1f}"
            print(f"{sp.stem[:26]:>26} x {clip.path.stem[:30]:<30} {100 * fm.drift_median:6.2f} / {100 * fm.drift_worst:5.2f} "
                  f"{acc:5.2f} ({fm.peak_acc:4.1f}/{max(fm.peak_acc_content, ex_acc):4.1f}) {100 * fm.jump_worst:5.2f} "
                  f"{100 * fm.floor_median:6.2f} / {100 * fm.floor_worst:5.2f} {sw:>5} / {sx:>5} "
                  f"{100 * row['before']:5.1f} -> {100 * row['after']:5.1f} ({100 * row['content_slide']:4.1f}; "
                  f"{100 * row['low_steps']:4.1f}){'' if row['cleaned'] else ' left'}",
                  flush=True)
    if rows:
        t = {k: torch.tensor([r[k] for r in rows]) for k in ("drift_median", "drift_worst", "acc_ratio", "jump",
                                                              "floor_median", "floor_worst", "before", "after")}
        worse = sum(r["after"] > r["before"] + 1e-9 for r in rows)
        print(f"results {len(rows)}: drift median of medians {100 * t['drift_median'].median():.2f} cm (target <= 1), "
              f"worst {100 * t['drift_worst'].max():.2f} cm (<= 3); acc ratio median {t['acc_ratio'].median():.2f}, "
              f"worst {t['acc_ratio'].max():.2f} (<= 1.5), {int((t['acc_ratio'] <= 1.5).sum())} of {len(rows)} within; "
              f"jump worst {100 * t['jump'].max():.2f} cm (<= 1.5; the contents' own worst "
              f"{100 * max(r['jump_content'] for r in rows):.2f}), {int((t['jump'] <= 0.015).sum())} of {len(rows)} within; floor median {100 * t['floor_median'].median():.2f} cm, "
              f"worst {100 * t['floor_worst'].max():.2f} cm (<= 0.5); sliding after > before on {worse} of {len(rows)} "
              f"(mean {100 * t['before'].mean():.1f}% -> {100 * t['after'].mean():.1f}%, of it low steps "
              f"{100 * sum(r['low_steps'] for r in rows) / len(rows):.1f}%); feet left as styled on "
              f"{sum(not r['cleaned'] for r in rows)}")
    if args.strength0 and styles:
        import tempfile

        from motioncore.bvh import read_bvh

        style = Style.load(styles[0])
        model = style_model(m.prior, style)
        for clip in clips:
            result, _ = stylize_motion(m, style, model, clip.canonical, 0.0, args.seed, feet=args.feet)
            with tempfile.TemporaryDirectory() as tmp:
                out = Path(tmp) / "out.bvh"
                write_result(clip, result, out)
                written, _ = read_bvh(out)
            a = clip.source.global_positions() if clip.source is not None else clip.canonical.global_positions()
            b = written.global_positions()
            scale = 1.0 if clip.rig is None else float(clip.rig.scale)
            err = float((a - b).norm(dim=-1).max()) * scale
            print(f"--strength 0: {clip.path.stem}: largest joint distance from the content on its own skeleton "
                  f"{1000 * err:.4f} mm (target <= 0.1)")


if __name__ == "__main__":
    main()
