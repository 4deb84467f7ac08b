"""The content bank (transfer.content_bank): what learning uses without a dataset cache, drawn by the prior."""
from __future__ import annotations

import statistics

import pytest
import torch

from mlcore.captions import BANDAI2_CONTENTS
from mlcore.dataset import MotionDataset
from motioncore.representation import FEATURES
from tests.helpers import tiny_denoiser
from transfer.bundle import MethodBundle
from transfer.content_bank import DATA_FRAMES, ContentBank, make_content_bank
from transfer.sampling import TextToMotion
from video2style.paths import default_dataset_dir


class _Words:
    """A stand-in text encoder: one fixed embedding per caption."""

    def encode(self, captions):
        return torch.stack([torch.randn(384, generator=torch.Generator().manual_seed(len(c))) for c in captions])


@pytest.mark.slow
def test_the_bank_draws_no_content_longer_than_the_prior_saw_it(tmp_path):
    assert set(DATA_FRAMES) == set(BANDAI2_CONTENTS)
    bundle = MethodBundle(tiny_denoiser(), torch.zeros(FEATURES.dim), torch.ones(FEATURES.dim), text_encoder=_Words())
    path = tmp_path / "bank.safetensors"
    n = make_content_bank(bundle, path, per_content=2, length=80, settings=TextToMotion(steps=2))
    bank = ContentBank(path)
    assert n == len(bank) == 2 * len(BANDAI2_CONTENTS) and bank.features.shape == (n, 80, FEATURES.dim)
    for i, r in enumerate(bank.records):
        assert r.length == min(80, DATA_FRAMES[r.content]) and bank.clip(i).shape == (r.length, FEATURES.dim)
        assert bool(bank.features[i, r.length:].eq(0).all()) and bool(bank.clip(i).ne(0).any())
    assert {r.length for r in bank.records if r.content == "run"} == {57}
    assert {r.length for r in bank.records if r.content == "walk"} == {80}


REAL_CACHE = default_dataset_dir()


@pytest.mark.skipif(not (REAL_CACHE / "clips.json").is_file(), reason="needs the real dataset cache (video2style dataset)")
def test_the_lengths_are_the_medians_of_the_datas_neutral_training_clips():
    records = MotionDataset(REAL_CACHE, "train").records
    for content, frames in DATA_FRAMES.items():
        lengths = [r.length for r in records if r.content == content and r.style == "normal" and not r.mirrored
                   and r.dataset == "bandai2"]
        assert int(statistics.median(lengths)) == frames, content
