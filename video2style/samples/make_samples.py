"""Regenerate the project-made demo inputs in this folder (no external data; needs the shipped prior).

    python video2style/samples/make_samples.py            # content clips + the style video
    python video2style/samples/make_samples.py --seed 3   # other draws

Content clips are text-to-motion samples of the project's diffusion prior (neutral style),
written as BVH on the canonical skeleton in centimetres at 30 fps. The style video is a prior
sample of an elderly-style walk rendered by the project's humanoid renderer
(:mod:`lifting.render_humanoid`), which the BlazePose tracker reads like a filmed person.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import torch

from motioncore.bvh import BvhLayout, write_bvh
from motioncore.motion import resample
from motioncore.skeleton import CANONICAL
from video2style.pipeline import prior_samples

HERE = Path(__file__).resolve().parent
CONTENT = {  # file stem -> caption
    "walk_prior": "a person walks",
    "run_prior": "a person runs",
    "walk_turn_left_prior": "a person walks and turns left",
    "wave_right_hand_prior": "a person waves the right hand",
}
STYLE_VIDEO = ("elderly", "a person walks, elderly style")


def main(argv: list[str] | None = None) -> None:
    from lifting.render_humanoid import frame_camera, write_humanoid_video

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=HERE)
    args = ap.parse_args(argv)
    torch.manual_seed(args.seed)
    names = [*CONTENT, STYLE_VIDEO[0]]
    motions = prior_samples([*CONTENT.values(), STYLE_VIDEO[1]], seed=args.seed)
    layout = BvhLayout.default(CANONICAL.skeleton, "ZXY", scale=0.01)  # centimetres, like most tools
    for name, motion in zip(names[:-1], motions[:-1]):
        write_bvh(args.out / f"{name}.bvh", resample(motion, 30.0), layout)
    style = resample(motions[-1], 30.0)
    cam = frame_camera(style.global_positions().numpy(), azimuth_deg=35.0, width=640, height=480)
    write_humanoid_video(style, cam, args.out / f"{STYLE_VIDEO[0]}.mp4")
    print("wrote", ", ".join(p.name for p in sorted(args.out.glob("*")) if p.suffix in (".bvh", ".mp4")))


if __name__ == "__main__":
    main()
