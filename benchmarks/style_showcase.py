"""Does a learned style show, and does the content survive? Measured on clips the settings were not chosen on.

    python benchmarks/style_showcase.py [--shared ../shared/data] [--out runs/showcase] [--strength 0.5]

1. SCUBA diver (``treadmill_32_SCUBA_Diver.mp4`` from 0.25 s: the clip opens with another walk) applied to the
   neutral Bandai-2 test walks: foot lift (highest ankle above its lowest, mean of both feet) of example,
   contents and results, and what the content classifier reads in the results.
2. Xia clips (styles the prior never saw) learned one by one and applied to neutral Bandai-2 test walks and
   runs: a style similarity that does not use our style classifier. Gram matrices of the raw joint rotation
   and position features, centred over time; ``gram ratio`` = ||G(result) - G(example)|| /
   ||G(content) - G(example)||, below 1 when the result moved towards the example; also on the position
   channels alone, which do not depend on how the example's rig rolls its bones.
3. Content safety: on the Bandai-2 test waves (normal style) the peak hand height of content and result;
   on the fair1 and Xia clips (the prior never saw them) the mean joint displacement from the content,
   next to the same number for the Bandai walks.
Previews of some results go to ``--out`` to be looked at. Needs ../shared/data and the dataset cache.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import torch

HANDS = ("Hand_L", "Hand_R")


def foot_lift(motion) -> float:
    from motioncore.skeleton import CANONICAL

    p = motion.global_positions()
    lifts = [float(p[:, leg[2], 1].max() - p[:, leg[2], 1].min()) for leg in CANONICAL.legs]
    return sum(lifts) / len(lifts)


def hand_peak(motion) -> float:
    from motioncore.skeleton import CANONICAL

    p = motion.global_positions()
    return float(max(p[:, CANONICAL.skeleton.index(n), 1].max() for n in HANDS))


def displacement(a, b) -> float:
    """Mean joint position difference (m) between two motions of the same length."""
    return float((a.global_positions() - b.global_positions()).norm(dim=-1).mean())


def gram(x: torch.Tensor, positions_only: bool = False) -> torch.Tensor:
    """Style descriptor of raw features ``(T, D)`` (metres, 6D rotations; not standardised with the Bandai
    statistics, which blow up channels that barely move in Bandai data): the covariance over time of the joint
    rotation and position channels (root path and contact flags left out; centred, so constant offsets from a
    skeleton's rest pose do not count, only how the body moves). ``positions_only``: the joint position channels
    alone, which do not depend on how a rig rolls its bones about themselves."""
    from motioncore.representation import FEATURES

    f = x[:, FEATURES.positions] if positions_only else torch.cat([x[:, FEATURES.positions], x[:, FEATURES.rotations]], -1)
    f = f - f.mean(0, keepdim=True)
    return f.T @ f / f.shape[0]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--shared", type=Path, default=Path(__file__).resolve().parents[1].parent / "shared" / "data")
    ap.add_argument("--out", type=Path, default=Path("runs/showcase"))
    ap.add_argument("--strength", type=float, default=0.5)
    ap.add_argument("--clips", type=int, default=4, help="Bandai test clips per content (default: %(default)s)")
    args = ap.parse_args()

    from evaluation.classifiers import default_weights, load_classifier, run_batched
    from mlcore.dataset import MotionDataset
    from motioncore.representation import decode, encode
    from transfer.bundle import load_models
    from transfer.spans import stylize_motion
    from transfer.style_file import Style, style_model
    from video2style.paths import default_dataset_dir
    from video2style.pipeline import learn_file, read_clip

    m = load_models()
    test = MotionDataset(default_dataset_dir(), "test")
    clf = load_classifier(default_weights("content"))
    out = args.out
    out.mkdir(parents=True, exist_ok=True)

    def bandai(content: str, style: str = "normal"):
        idx = [i for i, r in enumerate(test.records)
               if r.dataset == "bandai2" and not r.mirrored and r.content == content and r.style == style]
        return [(test.records[i].name, decode(test.clip(i, normalized=False))) for i in idx[: args.clips]]

    def learn(path: Path, name: str, span=(None, None)):
        style_path = out / f"{name}.v2s"
        if not style_path.is_file():
            learn_file(path, style_path, name.replace("_", " "), progress=lambda s: None, span=span)
        style = Style.load(style_path)
        return style, style_model(m.prior, style)

    def reads(motions) -> list[str]:
        feats = [clf.standardize(encode(x)) for x in motions]
        return [clf.config.classes[i] for i in run_batched(clf, feats, "logits").argmax(-1).tolist()]

    report: dict = {}
    walks, runs, waves = bandai("walk"), bandai("run"), bandai("wave-both-hands") + bandai("wave-left-hand") + bandai("wave-right-hand")
    # 1. SCUBA diver
    style, model = learn(args.shared / "videos" / "treadmill_32_SCUBA_Diver.mp4", "scuba_diver", (0.25, None))
    example = decode(style.example)
    report["scuba"] = {"example_foot_lift": foot_lift(example), "content_foot_lift": [foot_lift(x) for _, x in walks]}
    for strength in sorted({args.strength, 1.0}):
        results = [stylize_motion(m, style, model, x, strength)[0] for _, x in walks]
        report["scuba"][f"strength {strength:g}"] = {"result_foot_lift": [foot_lift(r) for r in results],
                                                     "result_read_as": reads(results)}
    results = [stylize_motion(m, style, model, x, args.strength)[0] for _, x in walks]
    print(json.dumps(report["scuba"], indent=1))
    _preview([walks[0][1], example, results[0]], ["content", "SCUBA example", "result"], out / "scuba_walk.mp4")

    # 2. Xia styles (and 3. wave peaks and displacement with each)
    report["xia"], report["waves"], report["foreign"] = {}, [], []
    foreign = sorted((args.shared / "bvh_misc").glob("fair1_*.bvh")) + sorted((args.shared / "xia_test").glob("*.bvh"))
    foreign_clips = [(p.name, read_clip(p).canonical) for p in foreign]
    for path in sorted((args.shared / "xia_test").glob("*.bvh")):
        if path.stem.startswith("neutral"):
            continue
        style, model = learn(path, f"xia_{path.stem}")
        ex = encode(decode(style.example))
        measures = (("gram_ratio", False), ("gram_ratio_positions", True))
        g_ex = {key: gram(ex, only) for key, only in measures}
        rows = []
        for name, x in walks + runs:
            r = stylize_motion(m, style, model, x, args.strength)[0]
            row = {"clip": name, "displacement": displacement(r, x)}
            for key, only in measures:
                g_c, g_r = gram(encode(x), only), gram(encode(r), only)
                row[key] = float((g_r - g_ex[key]).norm() / (g_c - g_ex[key]).norm())
            rows.append(row)
        report["xia"][path.stem] = rows
        ratio, ratio_pos, disp = (sum(r[k] for r in rows) / len(rows)
                                  for k in ("gram_ratio", "gram_ratio_positions", "displacement"))
        print(f"xia {path.stem}: gram ratio {ratio:.3f}, positions only {ratio_pos:.3f} (walks+runs), "
              f"displacement on Bandai {disp:.3f} m")
        for name, x in waves:
            r = stylize_motion(m, style, model, x, args.strength)[0]
            report["waves"].append({"style": path.stem, "clip": name, "content_peak": hand_peak(x), "result_peak": hand_peak(r)})
        for name, x in foreign_clips:
            r = stylize_motion(m, style, model, x, args.strength)[0]
            report["foreign"].append({"style": path.stem, "clip": name, "displacement": displacement(r, x)})
        if path.stem == "old_13_000":
            _preview([walks[0][1], decode(style.example), stylize_motion(m, style, model, walks[0][1], args.strength)[0]],
                     ["content", "Xia old", "result"], out / "xia_old_walk.mp4")
    drops = [w["content_peak"] - w["result_peak"] for w in report["waves"]]
    print(f"waves: hand peak change, content - result: max {max(drops):.3f} m, mean {sum(drops) / len(drops):.3f} m "
          f"over {len(drops)} (style, clip) pairs")
    fd = [f["displacement"] for f in report["foreign"]]
    print(f"foreign clips (fair1, Xia): mean joint displacement {sum(fd) / len(fd):.3f} m, max {max(fd):.3f} m")
    (out / "report.json").write_text(json.dumps(report, indent=1))
    print(f"wrote {out / 'report.json'}")


def _preview(motions, labels, path: Path) -> None:
    from motioncore.render import Panel, render_video
    from motioncore.skeleton import CANONICAL

    sk = CANONICAL.skeleton
    panels = [Panel(x.global_positions(), sk.parents, label, names=sk.names) for x, label in zip(motions, labels)]
    render_video(panels, path, CANONICAL.fps, size=(320, 320), progress=False)


if __name__ == "__main__":
    main()
