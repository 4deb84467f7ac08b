"""Where the models run: ``--device auto|cpu|cuda`` resolved to a ``torch.device``.

Importing this module does not import torch (``video2style --help`` stays fast); :func:`resolve_device` does.
The models and every tensor the method makes live on one device; random numbers are drawn on the CPU from
seeded ``torch.Generator`` objects and moved there, so a seed gives the same noise on any device, and results
come back to the CPU for the motion code (:mod:`motioncore` is CPU only).
"""
from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import torch

DEVICES = ("auto", "cpu", "cuda")
DEVICE_HELP = "where the models run: cpu (default), cuda (an NVIDIA GPU), or auto (cuda if torch sees one, else cpu)"


def resolve_device(name: str | torch.device) -> torch.device:
    """``"auto"``, ``"cpu"`` or ``"cuda"`` (or a ``torch.device``, returned as it is) -> ``torch.device``.

    auto: the current CUDA GPU if torch sees one, else the CPU. ValueError (one line) for ``"cuda"`` without a
    GPU and for any other name. A CUDA device comes with its index (``cuda:0``), as the models' tensors report it.
    """
    import torch

    if isinstance(name, torch.device):
        return name
    if name not in DEVICES:
        raise ValueError(f"--device: expected one of {', '.join(DEVICES)}, got {name!r}")
    if name == "cpu" or (name == "auto" and not torch.cuda.is_available()):
        return torch.device("cpu")
    if not torch.cuda.is_available():
        build = "a CPU build" if torch.version.cuda is None else f"built for CUDA {torch.version.cuda}"
        raise ValueError(f"--device cuda: torch sees no CUDA GPU (this torch is {torch.__version__}, {build}); "
                         "use --device cpu or auto")
    return torch.device("cuda", torch.cuda.current_device())


def model_device(model: torch.nn.Module) -> torch.device:
    """The device of ``model``'s parameters (the CPU for a model without any)."""
    import torch

    param = next(model.parameters(), None)
    return torch.device("cpu") if param is None else param.device
