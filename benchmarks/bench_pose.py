"""Benchmark the video -> 3-D pose pipeline: speed of `pose`, and accuracy against known truth.

    python -m benchmarks.bench_pose speed [VIDEO] [--frames N] [--no-preview]
    python -m benchmarks.bench_pose accuracy [--clips 10] [--keep DIR] [--json OUT]
    python -m benchmarks.bench_pose fit [--stride 10]

(from the repository root: it imports ``tests.lifting``).

speed: runs :func:`video2style.pose.pose_file` (the whole ``pose`` command: decoding,
BlazePose, fit, BVH, and the preview unless ``--no-preview``) on VIDEO, by default a 1280x720
30 fps render of a walking humanoid. Reports frames per second end to end, with model loading
excluded (it happens once per process) and also included.

accuracy: renders canonical motions of the Bandai-Namco test split (non-mirrored, one clip per
content) as 1280x720 30 fps videos of a simple humanoid (``lifting.render_humanoid``) seen by a
static pinhole camera (60 deg horizontal field of view, as the pipeline assumes, 1.5 m high,
from a side-ish/front-ish azimuth), runs the pipeline and compares with the truth:

* MPJPE: root (Hips) aligned per frame, plus one rotation about the vertical for the whole clip
  (the output is turned to face +Z at its start, the truth faces +Z at its start too);
* PA-MPJPE: per-frame similarity (Procrustes) alignment of the 21 joints;
* jitter: mean joint acceleration (m/s^2) of the global joint positions;
* root path: mean horizontal root error after one rigid alignment (rotation about the vertical
  and translation) for the clip, for each ``trajectory`` mode; lowest foot clearance (m, the
  floor is y = 0).

Each is given without the low-pass (``cutoff_hz=None``) and with it (3 Hz). Needs the dataset
cache (``video2style dataset``) and the BlazePose models.

fit: the skeleton fit alone (:func:`motioncore.ik_fit.fit_positions`) on the true joint positions
of the test clips: position error, and how far the fitted local rotations are from the data's
(the twist about a bone is not in the positions; the fit takes it from the reference pose).
"""

from __future__ import annotations

import argparse
import json
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from testkit.accuracy import acceleration, compare

REPO = Path(__file__).resolve().parents[1]  # the dataset cache's default place

AZIMUTHS = (30.0, -45.0, 60.0, -20.0, 45.0, -60.0, 20.0, -30.0, 50.0, -40.0)


def pick_clips(dataset, n: int) -> list[int]:
    """One non-mirrored clip per content (round robin over contents and styles), ``n`` in all."""
    by_content: dict[str, list[int]] = {}
    for i, r in enumerate(dataset.records):
        if not r.mirrored:
            by_content.setdefault(r.content, []).append(i)
    contents = sorted(by_content)
    picks, k = [], 0
    while len(picks) < n and any(by_content.values()):
        c = contents[k % len(contents)]
        if by_content[c]:
            # spread over styles: take clips at a stride through the content's list
            idx = by_content[c]
            picks.append(idx.pop((7 * (k // len(contents)) + 3 * contents.index(c)) % len(idx)))
        k += 1
    return picks


def accuracy(args) -> None:
    import torch

    torch.set_num_threads(1)
    from lifting.blazepose.tracker import PoseTracker
    from lifting.reconstruct import lift_track
    from lifting.render_humanoid import frame_camera, write_humanoid_video
    from lifting.tracking import track
    from mlcore.dataset import MotionDataset
    from motioncore.motion import resample
    from motioncore.representation import decode

    ds = MotionDataset(Path(args.data), "test")
    tracker = PoseTracker()
    rows = []
    keep = Path(args.keep) if args.keep else None
    with tempfile.TemporaryDirectory(prefix="bench-pose-") as tmp:
        folder = keep or Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        for k, i in enumerate(pick_clips(ds, args.clips)):
            rec = ds.records[i]
            truth = resample(decode(ds.clip(i, normalized=False)), args.fps)
            gt = truth.global_positions().double().numpy()
            az = AZIMUTHS[k % len(AZIMUTHS)]
            cam = frame_camera(gt, az, fov_deg=args.render_fov)
            video = write_humanoid_video(truth, cam, folder / f"{rec.name}.mp4")
            t0 = time.perf_counter()
            tracked = track(video, tracker=tracker)
            row = {"clip": rec.name, "content": rec.content, "azimuth": az, "frames": len(tracked.found),
                   "distance_m": float(np.linalg.norm(np.subtract(cam.eye, cam.target))),
                   "found": float(tracked.found.mean()), "track_fps": len(tracked.found) / (time.perf_counter() - t0),
                   "jitter_truth": acceleration(gt, args.fps)}
            for label, cutoff, traj in (("raw", None, "auto"), ("filtered", args.cutoff, "auto"),
                                        ("contacts", args.cutoff, "contacts"), ("camera", args.cutoff, "camera")):
                lifted = lift_track(tracked, str(video), cutoff, fov_deg=args.fov, trajectory=traj)
                pred = lifted.motion.global_positions().double().numpy()
                m = compare(pred, gt[lifted.start:lifted.stop], args.fps)
                row.update({f"{label}_{key}": v for key, v in m.items()})
                row[f"{label}_moving_ground"] = lifted.info["moving_ground"]
            rows.append(row)
            print(f"{rec.name:45s} az {az:+4.0f} {row['distance_m']:4.1f} m  found {row['found']:.0%}  "
                  f"PA {row['raw_pa_mpjpe_mm']:5.1f} -> {row['filtered_pa_mpjpe_mm']:5.1f}  "
                  f"MPJPE {row['raw_mpjpe_mm']:5.1f} -> {row['filtered_mpjpe_mm']:5.1f}  "
                  f"jitter {row['raw_jitter']:5.1f} -> {row['filtered_jitter']:5.1f} (truth {row['jitter_truth']:4.1f})  "
                  f"root {row['filtered_root_mm']:4.0f} (contacts {row['contacts_root_mm']:4.0f}, camera {row['camera_root_mm']:4.0f}) mm  "
                  f"min foot {min(row['filtered_min_foot_m'], row['camera_min_foot_m']):+.3f} m", flush=True)
    mean = {key: statistics.fmean(r[key] for r in rows) for key in rows[0] if isinstance(rows[0][key], float)}
    print(f"\nmean over {len(rows)} clips ({args.fps:g} fps, cutoff {args.cutoff:g} Hz):")
    for stage in ("raw", "filtered"):
        print(f"  {stage:9s} MPJPE {mean[f'{stage}_mpjpe_mm']:6.1f} mm  PA-MPJPE {mean[f'{stage}_pa_mpjpe_mm']:6.1f} mm  "
              f"jitter {mean[f'{stage}_jitter']:6.2f} m/s^2  root {mean[f'{stage}_root_mm']:6.0f} mm")
    print(f"  truth     jitter {mean['jitter_truth']:6.2f} m/s^2;  root path of the other modes: contacts "
          f"{mean['contacts_root_mm']:.0f} mm, camera {mean['camera_root_mm']:.0f} mm (jitter {mean['camera_jitter']:.2f});  "
          f"lowest foot {min(min(r[f'{k}_min_foot_m'] for k in ('raw', 'filtered', 'contacts', 'camera')) for r in rows):+.4f} m")
    if args.json:
        Path(args.json).write_text(json.dumps({"clips": rows, "mean": mean}, indent=1))


def fit(args) -> None:
    """The skeleton fit alone on true positions: FK of test clips -> fit -> positions and rotations."""
    import torch

    torch.set_num_threads(1)
    from mlcore.dataset import MotionDataset
    from motioncore import quat
    from motioncore.ik_fit import fit_positions
    from motioncore.representation import FEATURES, decode, encode
    from motioncore.skeleton import CANONICAL

    ds = MotionDataset(Path(args.data), "test")
    sk = CANONICAL.skeleton
    inner = [j for j in range(sk.num_joints) if sk.children(j)]
    variants = {"fit (reference pose + hinges)": {}, "no hinge twist": {"hinges": {}},
                "shortest arc from the T-pose": {"hinges": {}, "reference": quat.identity(sk.num_joints)}}
    clips = [i for i, r in enumerate(ds.records) if not r.mirrored][:: args.stride]
    for label, options in variants.items():
        pos, rot, feat, frames, seconds = [], [], [], 0, 0.0
        for i in clips:
            truth = decode(ds.clip(i, normalized=False))
            target = truth.global_positions()
            t0 = time.perf_counter()
            fitted = fit_positions(target, truth.fps, **options)
            seconds += time.perf_counter() - t0
            frames += truth.num_frames
            pos.append(float((fitted.global_positions() - target).norm(dim=-1).max()))
            rot.append(torch.rad2deg(quat.angle(quat.mul(quat.inv(truth.lrot[:, inner]), fitted.lrot[:, inner]))).mean())
            feat.append(float((encode(fitted) - encode(truth))[:, FEATURES.rotations].abs().mean()))
        print(f"{label:32s} {len(clips)} clips: max position error {1000 * max(pos):.4f} mm, local rotation error "
              f"{float(torch.stack(rot).mean()):5.1f} deg (joints with children), |6D feature error| {statistics.fmean(feat):.3f}, "
              f"{frames / seconds:.0f} frames/s")


def speed(args) -> None:
    import torch

    torch.set_num_threads(1)
    from lifting.blazepose.tracker import PoseTracker
    from video2style.pose import pose_file

    with tempfile.TemporaryDirectory(prefix="bench-pose-") as tmp:
        tmp = Path(tmp)
        video = args.video
        if video is None:
            video = _walking_video(tmp / "walk_720p.mp4", args.frames)
        preview = None if args.no_preview else tmp / "preview.mp4"
        t0 = time.perf_counter()
        tracker = PoseTracker()
        load = time.perf_counter() - t0
        pose_file(video, tmp / "warmup.bvh", None, progress=False, tracker=tracker)  # first-run allocations
        best = None
        for _ in range(args.repeats):
            s = pose_file(video, tmp / "out.bvh", preview, progress=False, tracker=tracker)
            best = s if best is None or s["seconds"] < best["seconds"] else best
        n = best["frames"]
        print(f"video: {Path(video).name}  {n} frames at {best['video_fps']:.2f} fps; preview: {'no' if preview is None else 'yes'}")
        print(f"pose: {best['seconds']:.2f} s = {n / best['seconds']:.1f} frames/s end to end "
              f"(tracking {best['track_seconds']:.2f} s, fit {best['fit_seconds']:.3f} s, preview {best['preview_seconds']:.2f} s; "
              f"best of {args.repeats})")
        print(f"with model loading ({load:.2f} s, once per process): {n / (best['seconds'] + load):.1f} frames/s")


def _walking_video(path: Path, frames: int) -> Path:
    """A 1280x720 30 fps render of a walking humanoid (a Bandai test clip when the dataset cache
    exists, else the synthetic stick figure of ``testkit.synthetic_blazepose``)."""
    try:
        from lifting.render_humanoid import frame_camera, write_humanoid_video
        from mlcore.dataset import MotionDataset
        from motioncore.motion import resample
        from motioncore.representation import decode

        ds = MotionDataset(REPO / "cache" / "dataset", "test")
        i = next(k for k, r in enumerate(ds.records) if r.content == "walk" and not r.mirrored)
        m = resample(decode(ds.clip(i, normalized=False)), 30.0)
        m = m.slice(0, min(frames, m.num_frames))
        return write_humanoid_video(m, frame_camera(m.global_positions().numpy(), 40.0), path)
    except (FileNotFoundError, StopIteration, ImportError):
        from testkit.synthetic_blazepose import write_walking_clip

        return write_walking_clip(path, 1280, 720, n_frames=frames)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="mode", required=True)
    sp = sub.add_parser("speed", help="frames per second of the pose command")
    sp.add_argument("video", nargs="?", type=Path, help="video file (default: a 720p humanoid render)")
    sp.add_argument("--frames", type=int, default=150, help="length of the default clip")
    sp.add_argument("--no-preview", action="store_true", help="time the BVH only")
    sp.add_argument("--repeats", type=int, default=2, help="timed runs; the fastest is reported")
    ac = sub.add_parser("accuracy", help="MPJPE / PA-MPJPE / jitter on rendered test clips")
    ac.add_argument("--clips", type=int, default=10)
    ac.add_argument("--data", default=str(REPO / "cache" / "dataset"))
    ac.add_argument("--fps", type=float, default=30.0, help="frame rate of the renders")
    ac.add_argument("--cutoff", type=float, default=3.0, help="low-pass cutoff (Hz) of the filtered run")
    ac.add_argument("--fov", type=float, default=60.0, help="field of view the pipeline assumes")
    ac.add_argument("--render-fov", type=float, default=60.0, help="field of view of the render camera")
    ac.add_argument("--keep", help="keep the rendered videos in this folder")
    ac.add_argument("--json", help="write per-clip numbers here")
    ft = sub.add_parser("fit", help="the skeleton fit on true positions of the test clips")
    ft.add_argument("--data", default=str(REPO / "cache" / "dataset"))
    ft.add_argument("--stride", type=int, default=10, help="every N-th non-mirrored test clip")
    args = parser.parse_args(argv)
    {"speed": speed, "accuracy": accuracy, "fit": fit}[args.mode](args)


if __name__ == "__main__":
    main()
