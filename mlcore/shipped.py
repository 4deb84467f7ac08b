"""Where the trained weights are: ``$VIDEO2STYLE_WEIGHTS`` if set, else the ones shipped in ``mlcore/weights/``.

The one place that decides it: loading (``video2style``), the default output of training commands
(classifiers, Park et al.'s stylizer) and the derived caption table all go through here.
"""
from __future__ import annotations

import os
from pathlib import Path

SHIPPED = Path(__file__).resolve().parent / "weights"
ENV = "VIDEO2STYLE_WEIGHTS"


def weights_dir() -> Path:
    """``$VIDEO2STYLE_WEIGHTS`` if set, else the package's ``mlcore/weights/``."""
    return Path(os.environ[ENV]).expanduser() if os.environ.get(ENV) else SHIPPED


def weights_path(name: str) -> Path:
    """An existing model file ``name`` in :func:`weights_dir`; FileNotFoundError saying how to get it."""
    path = weights_dir() / name
    if not path.is_file():
        raise FileNotFoundError(f"{path}: model weights missing (train them with video2style train-prior / train-encoder, "
                                f"or set {ENV} to a folder holding them)")
    return path
