"""``video2style demo``: the whole job on the project-made inputs in ``samples/`` (installed as ``video2style.samples``).

1. ``pose``: each sample video -> BVH + a preview of the landmarks beside the fitted skeleton;
2. ``batch``: learn each video's style (the file name gives the style words) and apply it to every
   sample BVH clip -> stylised BVH, previews, a summary table and ``index.html``.
"""
from __future__ import annotations

from importlib.resources import files
from pathlib import Path

# the repository's samples/, package data of video2style.samples (setup.py): found in a wheel and an editable install
SAMPLES = Path(str(files("video2style.samples")))


def run_demo(out_dir: Path, progress=print, samples: Path = SAMPLES):
    """Runs pose and batch on ``samples``; returns the batch report (see :mod:`video2style.batch`)."""
    from video2style.batch import (
        check_batch_outputs,
        find_videos,
        run_batch,
        video_keys,
    )
    from video2style.paths import check_outputs
    from video2style.pose import pose_file

    out_dir = Path(out_dir)
    from video2style.pipeline import find_bvh_files

    clips, videos = find_bvh_files(samples, recursive=False), find_videos(samples)
    if not clips or not videos:
        raise FileNotFoundError(f"{samples}: expected sample .bvh clips and videos (run python samples/make_samples.py)")
    check_outputs([("-o", out_dir / "pose" / f"{v.stem}{end}") for v in videos for end in (".bvh", "_pose.mp4")],
                  [("the sample", p) for p in clips + videos])
    check_batch_outputs(samples, samples, out_dir, list(video_keys(videos).values()))
    out_dir.mkdir(parents=True, exist_ok=True)
    from lifting.blazepose.assets import WHEEL_ABOUT, find_models

    if find_models() is None:  # said before pip starts: a first demo on a fresh machine downloads
        progress(f"first use: fetching the pose models from {WHEEL_ABOUT}, once (offline: video2style models "
                 "--wheel FILE first)")
    progress(f"samples: {len(videos)} video(s) ({', '.join(v.name for v in videos)}), "
        f"{len(clips)} clip(s) ({', '.join(c.name for c in clips)})")
    for video in videos:
        info = pose_file(video, out_dir / "pose" / f"{video.stem}.bvh", out_dir / "pose" / f"{video.stem}_pose.mp4", progress=False)
        progress(f"pose: {video.name} -> {info['bvh']} ({info['bvh_frames']} frames at {info['bvh_fps']:g} fps, "
                 f"{info['bvh_seconds']:.2f} s; tracked at {info['fps']:.0f} video frames a second), "
                 f"preview {info['preview']}")
    report = run_batch(samples, samples, out_dir, progress=progress)  # apply's defaults: --strength 0.5
    progress(report.table())
    progress(f"open {out_dir / 'index.html'} to see every result beside its content clip and style example")
    return report
