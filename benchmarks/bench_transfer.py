"""Speed of ``learn`` (pose included) and ``apply`` on 10-second clips, and the style file size.

    python benchmarks/bench_transfer.py [--seconds 10] [--threads 2] [--work DIR] [--learn-repeats 3]

Inputs are project-made: a prior sample of "a person walks, elderly style" rendered as a 720p
video of the project's humanoid (the style example), and a prior sample of "a person walks" as
a 30 fps BVH (the content), each drawn whole: longer than the prior's 80-frame window, they shuffle, and the
style example is read as an arm action (these are speed inputs, not quality ones). Targets (issue 5): learn <= 90 s,
apply <= 1 s per 10 s clip (cleanup included), style file <= 1 MB. ``--learn-repeats`` times learn several times,
each with its steps apart. Previews are off for the apply timing; the time with a
preview and with neutralisation (styled content) is printed too.
"""
from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import torch


def make_inputs(work: Path, seconds: float) -> tuple[Path, Path]:
    from lifting.render_humanoid import frame_camera, write_humanoid_video
    from motioncore.bvh import BvhLayout, write_bvh
    from motioncore.motion import resample
    from motioncore.skeleton import CANONICAL
    from video2style.pipeline import prior_samples

    frames = round(seconds * CANONICAL.fps)
    style, content = prior_samples(["a person walks, elderly style", "a person walks"], frames=frames, seed=1)
    style30 = resample(style, 30.0)
    video = write_humanoid_video(style30, frame_camera(style30.global_positions().numpy(), 35.0), work / "elderly.mp4")
    bvh = work / "walk.bvh"
    write_bvh(bvh, resample(content, 30.0), BvhLayout.default(CANONICAL.skeleton, "ZXY", scale=0.01))
    return video, bvh


def _phase_seconds(phases: list[tuple[float, str]], end: float) -> list[tuple[str, float]]:
    """Seconds spent in each of learn's numbered steps ("[1/4] ..."), from its timestamped progress lines."""
    starts = [(t, s.split("]")[0] + "]") for t, s in phases if s.startswith("[")]
    ends = [t for t, _ in starts[1:]] + [end]
    return [(label, end - start) for (start, label), end in zip(starts, ends)]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--work", type=Path, help="keep inputs and outputs here (default: a temporary folder)")
    ap.add_argument("--repeats", type=int, default=3, help="apply timings: best of this many")
    ap.add_argument("--learn-repeats", type=int, default=1, help="learn this many times (each timed, phases apart)")
    ap.add_argument("--device", default="cpu", help="where the models run: cpu, cuda or auto (default: %(default)s)")
    args = ap.parse_args()
    torch.set_num_threads(args.threads)

    from transfer.bundle import load_models
    from video2style.loaded_style import LoadedStyle
    from video2style.options import ApplyOptions
    from video2style.pipeline import learn_file

    with tempfile.TemporaryDirectory() as tmp:
        work = args.work or Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        video, bvh = make_inputs(work, args.seconds)
        t0 = time.perf_counter()
        load_models(args.device)
        print(f"device {args.device}; loading models: {time.perf_counter() - t0:.1f} s (once per process, not counted below)")

        for run in range(args.learn_repeats):
            phases: list[tuple[float, str]] = []
            t0 = time.perf_counter()
            summary = learn_file(video, work / "elderly.v2s", "elderly", device=args.device,
                                 progress=lambda s, lines=phases: lines.append((time.perf_counter(), s)))
            learn_s = time.perf_counter() - t0
            print(f"learn ({args.seconds:g} s 720p video, pose included), run {run + 1}: {learn_s:.1f} s "
                  f"({summary['iterations']} fine-tuning iterations; content read as {summary['content']!r})  "
                  "target <= 60 s")
            print("  " + "; ".join(f"{label} {seconds:.1f} s" for label, seconds in _phase_seconds(phases, t0 + learn_s)))
        size = (work / "elderly.v2s").stat().st_size
        print(f"style file: {size / 1024:.0f} KiB  target <= 1024 KiB")

        style = LoadedStyle.from_file(work / "elderly.v2s", device=args.device)
        for label, kw in [("apply, no preview", {"preview": False, "neutralize": "never"}),
                          ("apply, content recognised first (auto)", {"preview": False, "neutralize": "auto"}),
                          ("apply, neutralised first (styled content)", {"preview": False, "neutralize": "always"}),
                          ("apply with preview", {"preview": True, "neutralize": "never"})]:
            times = []
            for _ in range(args.repeats):
                t0 = time.perf_counter()
                style.apply(bvh, work / "out", ApplyOptions(strength=0.5, **kw))
                times.append(time.perf_counter() - t0)
            print(f"{label} ({args.seconds:g} s clip, 30 fps BVH in and out, cleanup included): "
                  f"best {min(times):.2f} s, mean {sum(times) / len(times):.2f} s" + ("  target <= 1 s" if label.startswith("apply, no") else ""))


if __name__ == "__main__":
    main()
