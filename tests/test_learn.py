"""Style learning (Hu et al. §3.2-3.5) with toy models: a tiny prior and motion encoder, a hashed text encoder."""
from __future__ import annotations

import hashlib

import pytest
import torch

from motioncore.representation import FEATURES
from tests.synthetic_cache import write_synthetic_cache
from transfer.dataset import MotionDataset
from transfer.denoiser import Denoiser, DenoiserConfig
from transfer.motion_encoder import MotionEncoder, MotionEncoderConfig
from transfer.style import StyleConfig, learn_style, style_model


class HashedText:
    """Deterministic unit vectors per text: a stand-in for the sentence encoder."""

    def encode(self, texts):
        out = []
        for t in texts:
            seed = int(hashlib.sha1(t.encode()).hexdigest()[:8], 16)
            v = torch.randn(384, generator=torch.Generator().manual_seed(seed))
            out.append(v / v.norm())
        return torch.stack(out)


@pytest.fixture(scope="module")
def toys(tmp_path_factory):
    torch.manual_seed(0)
    prior = Denoiser(DenoiserConfig(width=32, layers=2, heads=2, ff=64, dropout=0.0)).eval()
    encoder = MotionEncoder(MotionEncoderConfig(width=32, layers=1, heads=2, ff=64, dropout=0.0)).eval()
    for p in encoder.parameters():
        p.requires_grad_(False)
    cache = write_synthetic_cache(tmp_path_factory.mktemp("cache"))
    return prior, encoder, HashedText(), cache


def _config(**kw):
    return StyleConfig(iterations=4, max_seconds=30, pair_steps=3, transfer_steps=2, content_batch=2, window=24, **kw)


def test_learn_style_trains_only_adapters_and_records_metadata(toys):
    prior, encoder, text, cache = toys
    data = MotionDataset(cache, "train")
    example = data.clip(0)
    before = {k: v.clone() for k, v in prior.state_dict().items()}
    style, info = learn_style(prior, encoder, text, data, example, "elderly", "walk", _config())
    assert all(torch.equal(before[k], v) for k, v in prior.state_dict().items())  # the prior is untouched
    assert style.meta["iterations"] == 4 and style.meta["content"] == "a person walks"
    assert info["pair"].shape == example.shape and len(info["history"]) == 4
    assert all(torch.isfinite(torch.tensor(h)).all() for h in info["history"])
    assert any(k.endswith("lora_b") and v.abs().max() > 0 for k, v in style.adapters.items())  # adapters moved from zero
    # the neutral pair keeps the example's path on the ground (inpainted root velocities)
    for sl in (FEATURES.root_rvel, FEATURES.root_lvel):
        assert torch.allclose(info["pair"][:, sl], example[:, sl], atol=1e-5)
    model = style_model(prior, style)
    x, t = torch.randn(1, 24, FEATURES.dim), torch.tensor([300])
    assert not torch.allclose(model(x, t), prior(x, t))


def test_learn_style_is_seeded_and_ablation_skips_the_pair(toys):
    prior, encoder, text, cache = toys
    data = MotionDataset(cache, "train")
    a, _ = learn_style(prior, encoder, text, data, data.clip(1), "old", "walk", _config())
    b, _ = learn_style(prior, encoder, text, data, data.clip(1), "old", "walk", _config())
    assert all(torch.equal(a.adapters[k], b.adapters[k]) for k in a.adapters)
    _, info = learn_style(prior, encoder, text, data, data.clip(1), "old", "walk", _config(pair_generation=False))
    assert torch.equal(info["pair"], data.clip(1))
    with pytest.raises(ValueError, match="expected an example"):
        learn_style(prior, encoder, text, data, torch.zeros(10, 5), "old", "walk", _config())


def test_evaluation_method_learns_once_per_example(toys):
    from types import SimpleNamespace

    from video2style.evaluate import OnTheFly

    prior, encoder, text, cache = toys
    data = MotionDataset(cache, "train")
    models = SimpleNamespace(prior=prior, motion_encoder=encoder, text_encoder=text)
    method = OnTheFly(models, data, _config(), seed=0)
    test = MotionDataset(cache, "test")
    style, content = test.clip(0), test.clip(3)
    out1 = method(content, style, "elderly", "walk")
    out2 = method(test.clip(5), style, "elderly", "walk")
    assert out1.shape == content.shape and torch.isfinite(out1).all() and out2.shape == test.clip(5).shape
    assert len(method.learn_seconds) == 1  # the second call reused the learned style
    method(content, test.clip(2), "elderly", "walk")  # (clip 1 is clip 0's mirrored copy: same features here)
    assert len(method.learn_seconds) == 2
