"""What FBX/glTF in and out costs in a batch, beside the styling itself, and how exact the round trips are.

    python -m benchmarks.bench_interchange [--clips 8] [--seconds 4] [--formats fbx glb]   # from the repository root

Builds clips of the generated rig corpus (Mixamo, UE5 mannequin, Rigify conventions) as FBX and GLB with
Blender (video2style.interchange), then in one Converter (one Blender process), as a batch does:
Blender's start, reading each clip to BVH, and writing a result back onto the clip's own file; beside that
the time `LoadedStyle.apply` takes on the same clip as `batch` calls it (a zero style: the full diffusion,
cleanup and preview cost). Also the
largest joint gap of BVH -> file -> BVH and of the result keyed back onto the file (mm).
Needs Blender with numpy (or the bpy module); no data from ../shared.
"""
from __future__ import annotations

import argparse
import copy
import statistics
import tempfile
import time
from pathlib import Path

import torch

from motioncore.bvh import read_bvh, write_bvh
from motioncore.retarget import from_canonical, make_rig
from testkit.motions import random_motion
from testkit.rig_corpus import case
from video2style.interchange import Converter


def gap_mm(a: Path, b: Path) -> float:
    ma, _ = read_bvh(a)
    mb, _ = read_bvh(b)
    pa, pb = ma.global_positions(), mb.global_positions()
    idx = [mb.skeleton.names.index(n) for n in ma.skeleton.names]
    return 1000 * float((pa - pb[:, idx]).norm(dim=-1).max())


def zero_style(folder: Path):
    from transfer.bundle import load_models
    from transfer.lora import add_lora, lora_state
    from transfer.style_file import Style

    model = copy.deepcopy(load_models().prior)
    add_lora(model, rank=8)
    path = folder / "zero.v2s"
    Style({k: torch.zeros_like(v) for k, v in lora_state(model).items()}, {"style": "zero", "rank": 8}).save(path)
    from video2style.loaded_style import LoadedStyle

    return LoadedStyle.from_file(path)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--clips", type=int, default=8, help="clips per format (default: %(default)s)")
    ap.add_argument("--seconds", type=float, default=4.0, help="length of each clip (default: %(default)s)")
    ap.add_argument("--formats", nargs="+", default=["fbx", "glb"])
    args = ap.parse_args()
    torch.set_num_threads(1)
    from video2style.options import ApplyOptions

    rigs = ["mixamo", "ue5", "rigify"]
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        style = zero_style(tmp)
        with Converter() as maker:  # the inputs (not timed)
            clips = {}
            for fmt in args.formats:
                for i in range(args.clips):
                    rig = rigs[i % len(rigs)]
                    c = case(rig)
                    bvh = tmp / "src" / fmt / f"{rig}_{i}.bvh"
                    bvh.parent.mkdir(parents=True, exist_ok=True)
                    motion = random_motion(seconds=args.seconds, fps=30.0, seed=i, amplitude=0.3)
                    write_bvh(bvh, from_canonical(motion, make_rig(c.skeleton)), c.layout)
                    clips.setdefault(fmt, []).append((rig, bvh, maker.write(bvh, bvh.with_suffix(f".{fmt}"))))
        print(f"{args.clips} clips per format of {args.seconds:g} s at 30 fps (rigs {', '.join(rigs)}), 1 torch thread")
        print("| format | Blender start s | read clip -> BVH s (median) | apply s (median) | write result -> file s (median) "
              "| conversion share of a clip | BVH->file->BVH max gap mm | result on file max gap mm |")
        print("|---|---:|---:|---:|---:|---:|---:|---:|")
        for fmt, items in clips.items():
            conv = Converter()
            reads, applies, writes, gaps, gaps_back = [], [], [], [], []
            start = None
            for rig, bvh, clip in items:
                t = time.perf_counter()
                back = conv.to_bvh(clip)
                dt = time.perf_counter() - t
                if start is None:  # the first read includes Blender's start: measured apart below
                    start = dt
                else:
                    reads.append(dt)
                gaps.append(gap_mm(bvh, back))
                out = tmp / "out" / fmt / rig
                t = time.perf_counter()
                info = style.apply(back, out, ApplyOptions(strength=0.5, seed=0))  # as batch runs it: preview included
                applies.append(time.perf_counter() - t)
                t = time.perf_counter()
                written = conv.write(info.output, Path(info.output).with_suffix(f".{fmt}"), source=clip)
                writes.append(time.perf_counter() - t)
                gaps_back.append(gap_mm(Path(info.output), conv.to_bvh(written)))
            conv.close()
            read_med = statistics.median(reads)
            start_only = start - read_med
            share = (read_med + statistics.median(writes)) / (read_med + statistics.median(writes) + statistics.median(applies))
            print(f"| {fmt} | {start_only:.2f} | {read_med:.2f} | {statistics.median(applies):.2f} | "
                  f"{statistics.median(writes):.2f} | {100 * share:.0f} % | {max(gaps):.4f} | {max(gaps_back):.4f} |")
    skinned()


def skinned() -> None:
    """A skinned character through `video2style apply` (a zero style) in its own format: what the file keeps."""
    from testkit.clips import corpus_bvh, run_script, twist_deg, zero_style
    from testkit.rig_corpus import case
    from video2style.cli import main as cli

    print("\n| clip | mesh, weights, materials kept | rest pose max change | role-bone twist median / p99 / max deg "
          "| joints max move mm (zero style, feet cleaned) |")
    print("|---|---|---:|---:|---:|")
    for rig, fmt in (("mixamo", "fbx"), ("ue5", "glb"), ("rigify", "fbx")):
        with tempfile.TemporaryDirectory() as tmp:
            tmp = Path(tmp)
            bvh = corpus_bvh(tmp / "src", rig, seconds=4.0)
            with Converter() as conv:
                bare = conv.write(bvh, tmp / "src" / f"bare.{fmt}")
            clip = tmp / "in" / f"walk.{fmt}"
            clip.parent.mkdir()
            run_script("skin", bare, out=str(clip), format=fmt)
            assert cli(["apply", str(zero_style(tmp)), str(clip), "-o", str(tmp / "out"), "--no-preview"]) == 0
            a, b = run_script("inspect", clip), run_script("inspect", tmp / "out" / f"walk.{fmt}")
            rest = max(abs(x - y) for n in a["bones"] for ra, rb in zip(a["bones"][n], b["bones"][n]) for x, y in zip(ra, rb))
            roles = {j for j in case(rig).expected.values() if j}
            tw = sorted(twist_deg(pa[n][1], pb[n][1]) for pa, pb in zip(a["poses"], b["poses"]) for n in roles)
            heads = torch.tensor([[pa[n][0] for n in pa] for pa in a["poses"]])
            heads_b = torch.tensor([[pb[n][0] for n in pa] for pa, pb in zip(a["poses"], b["poses"])])
            unit = 1000 * (0.01 if float(heads[..., 2].amax()) > 20 else 1.0)  # Blender units: cm or m
            print(f"| {rig} {fmt} | {a['meshes'] == b['meshes']} | {rest:.1e} | {statistics.median(tw):.1f} / "
                  f"{tw[int(0.99 * (len(tw) - 1))]:.1f} / {tw[-1]:.1f} | {unit * float((heads - heads_b).norm(dim=-1).max()):.1f} |")


if __name__ == "__main__":
    main()
