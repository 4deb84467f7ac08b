"""Regenerate the project-made demo inputs in this folder (no external data; needs the shipped prior).

    python samples/make_samples.py                 # content clips + the style video
    python samples/make_samples.py --seed 3        # other draws (default 2)
    python samples/make_samples.py --content-bank  # also the shipped content bank (mlcore/weights)

Content clips are text-to-motion samples of the project's diffusion prior (neutral style; the project's
``transfer.sampling.TextToMotion`` settings), their rotations fitted to the samples' joint-position channels
(:func:`motioncore.ik_fit.decode_via_positions`: bone rolls in the data's convention; the rotation channels'
own rolls drift, and apply would read such a clip as a foreign rig; ``--from-rotations`` decodes the rotation
channels instead), written as BVH on the canonical skeleton in centimetres at 30 fps. Each is
drawn as long as the prior's training clips of its action (``transfer.content_bank.DATA_FRAMES``), at most 80
frames (4 s, the prior's window): the run 57 (drawn longer, a run lifts its feet less,
docs/archive/RESULTS-notebook.md#the-prior-draws-well-only-as-long-as-its-training-windows-issue-24).
The style video is a prior
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
from transfer.content_bank import DATA_FRAMES
from video2style.pipeline import prior_samples

HERE = Path(__file__).resolve().parent
CONTENT = {  # file stem -> (caption, frames at the prior's 20 fps)
    "walk_prior": ("a person walks", 80),
    "run_prior": ("a person runs", min(80, DATA_FRAMES["run"])),
    "walk_turn_left_prior": ("a person walks and turns left", 80),
    "wave_right_hand_prior": ("a person waves the right hand", 80),
}
STYLE_VIDEO = ("elderly", "a person walks, elderly style", 80)


def main(argv: list[str] | None = None) -> None:
    from lifting.render_humanoid import frame_camera, write_humanoid_video

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    # seed 2: of the draws 0-2, the one whose walk, turn and run slide least and lift most, for the 34,000-step prior,
    # the 35,743-step one and its planted-feet guide
    # (docs/archive/RESULTS-notebook.md#everything-downstream-remade-issue-24-item-5: seed 0's turn slides
    # in 8.9 % of frames, seed 1's turn lifts 12.3 cm; seed 2 slides in no frame)
    ap.add_argument("--seed", type=int, default=2)
    ap.add_argument("--out", type=Path, default=HERE)
    ap.add_argument("--from-rotations", action="store_true", help="decode the samples' rotation channels")
    ap.add_argument("--content-bank", action="store_true",
                    help="also remake the content bank that learning uses without a dataset cache "
                         "(mlcore/weights/content_bank.safetensors and its card) from the shipped prior")
    args = ap.parse_args(argv)
    torch.manual_seed(args.seed)
    if args.content_bank:
        write_content_bank()
    wanted = {**CONTENT, STYLE_VIDEO[0]: STYLE_VIDEO[1:]}
    motions = {}
    for frames in sorted({n for _, n in wanted.values()}, reverse=True):  # one batch per length
        names = [name for name, (_, n) in wanted.items() if n == frames]
        drawn = prior_samples([wanted[name][0] for name in names], frames, args.seed, from_positions=not args.from_rotations)
        motions.update(zip(names, drawn))
    layout = BvhLayout.default(CANONICAL.skeleton, "ZXY", scale=0.01)  # centimetres, like most tools
    for name in CONTENT:
        write_bvh(args.out / f"{name}.bvh", resample(motions[name], 30.0), layout)
    style = resample(motions[STYLE_VIDEO[0]], 30.0)
    cam = frame_camera(style.global_positions().numpy(), azimuth_deg=35.0, width=640, height=480)
    write_humanoid_video(style, cam, args.out / f"{STYLE_VIDEO[0]}.mp4")
    print("wrote", ", ".join(p.name for p in sorted(args.out.glob("*")) if p.suffix in (".bvh", ".mp4")))


def write_content_bank(per_content: int = 4, length: int = 80, seed: int = 0) -> Path:
    """The shipped content bank, sampled from the shipped prior (:func:`transfer.content_bank.make_content_bank`,
    the project's :class:`transfer.sampling.TextToMotion` settings), with its model card."""
    import json
    import time
    from dataclasses import asdict

    from mlcore.shipped import weights_path
    from motioncore.files import atomic_write_text
    from transfer.content_bank import make_content_bank
    from transfer.sampling import TEXT_TO_MOTION
    from video2style.pipeline import load_models

    models, settings = load_models(), TEXT_TO_MOTION
    path = weights_path("content_bank.safetensors")
    start = time.time()
    n = make_content_bank(models, path, per_content, length, seed, settings)
    card = {
        "model": "video2style content bank: neutral content motions for style learning when no dataset cache is installed",
        "made_by": "python samples/make_samples.py --content-bank: transfer.content_bank.make_content_bank "
                   f"with the shipped denoiser.safetensors, seed {seed}",
        "text_to_motion": asdict(settings),
        "contents": f"{per_content} samples x 10 Bandai-2 contents ({n} clips), each as long as the prior's training "
                    f"clips of its content (transfer.content_bank.DATA_FRAMES), at most {length} frames, zero-padded to "
                    f"{length}; normalised features, float16",
        "licence": "CC BY-NC 4.0, inherited from the prior's Bandai-Namco training data",
        "machine": "2 CPU cores",
        "seconds": round(time.time() - start, 1),
        "date": time.strftime("%Y-%m-%d"),
    }
    atomic_write_text(path.with_suffix(".json"), json.dumps(card, indent=1) + "\n")
    print(f"wrote {path} ({n} clips)")
    return path


if __name__ == "__main__":
    main()
