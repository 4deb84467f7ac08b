"""What the benchmarks share: style files learned from examples once and reused."""
from __future__ import annotations

from pathlib import Path


def learned_styles(examples, styles_dir: Path) -> list[Path]:
    """The style file of each example (video or BVH) in ``styles_dir`` (``<stem>.v2s``), learned with the defaults
    (:func:`video2style.pipeline.learn_file`) where it is not there yet."""
    from video2style.pipeline import learn_file

    paths = []
    for example in examples:
        path = Path(styles_dir) / f"{Path(example).stem}.v2s"
        if not path.is_file():
            path.parent.mkdir(parents=True, exist_ok=True)
            learn_file(Path(example), path, progress=lambda s: None)
        paths.append(path)
    return paths
