"""``video2style demo``: what the tool does, on the project-made clips in ``samples/``."""
from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

from video2style.paths import PACKAGE_ROOT

SAMPLES = PACKAGE_ROOT / "samples"


def sample_clips() -> list[Path]:
    clips = sorted(SAMPLES.glob("*.bvh"))
    if not clips:
        raise FileNotFoundError(f"{SAMPLES}: no sample clips (run python samples/make_samples.py)")
    return clips


def run_demo(out_dir: Path) -> Iterator[str]:
    """Runs each stage that exists so far on the samples; yields one line per result."""
    from video2style.preview import preview_bvh_files

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    clips = sample_clips()
    yield f"samples: {', '.join(c.name for c in clips)}"
    out = preview_bvh_files(clips, out_dir / "samples_canonical.mp4", canonical=True)
    yield f"preview of the samples on the canonical skeleton: {out}"
