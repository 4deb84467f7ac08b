"""The method's models in one bundle (transfer.bundle): the normalisation its code uses everywhere, and loading."""
from __future__ import annotations

from pathlib import Path

import pytest
import torch

from mlcore.shipped import weights_path
from motioncore.representation import FEATURES
from tests.helpers import tiny_denoiser
from transfer.bundle import ENCODER_FILE, PRIOR_FILE, MethodBundle, load_models


def test_the_bundle_normalises_as_the_hand_written_formulas_did_and_builds_its_scheduler():
    g = torch.Generator().manual_seed(0)
    mean, std = torch.randn(FEATURES.dim, generator=g), torch.rand(FEATURES.dim, generator=g) + 0.1
    bundle = MethodBundle(tiny_denoiser(), mean, std)
    x = torch.randn(30, FEATURES.dim, generator=g)
    assert torch.equal(bundle.normalize(x), (x - mean) / std)  # bit for bit: no behaviour moves with the code
    assert torch.equal(bundle.denormalize(x), x * std + mean)
    y = x.clone()
    assert bundle.normalize(y, inplace=True) is y and torch.equal(y, (x - mean) / std)
    assert bundle.denormalize(y, inplace=True) is y and torch.allclose(y, x, atol=1e-5)
    assert bundle.scheduler.num_train_steps == bundle.prior.config.num_train_steps


def test_from_pretrained_names_a_missing_weights_file(tmp_path):
    with pytest.raises(FileNotFoundError, match=PRIOR_FILE):
        MethodBundle.from_pretrained(tmp_path)
    with pytest.raises(FileNotFoundError, match="nothing.safetensors"):
        MethodBundle.from_pretrained((weights_path(PRIOR_FILE), tmp_path / "nothing.safetensors"))


@pytest.mark.skipif(not weights_path(PRIOR_FILE).is_file(), reason="shipped weights not present")
def test_a_folder_and_its_two_files_load_the_same_bundle_as_the_shipped_one():
    shipped = load_models()
    assert load_models("cpu") is shipped  # once per process and device
    folder = MethodBundle.from_pretrained(Path(weights_path(PRIOR_FILE)).parent)
    files = MethodBundle.from_pretrained((weights_path(PRIOR_FILE), weights_path(ENCODER_FILE)))
    for b in (folder, files):
        assert b.prior_path == shipped.prior_path and torch.equal(b.mean, shipped.mean) and torch.equal(b.std, shipped.std)
        assert all(torch.equal(p, q) for p, q in zip(b.prior.state_dict().values(), shipped.prior.state_dict().values()))


def test_text_to_motion_draws_with_the_settings_and_the_guide_only_when_asked():
    from transfer.sampling import TEXT_TO_MOTION, TextToMotion, generate

    g = torch.Generator().manual_seed(1)
    bundle = MethodBundle(tiny_denoiser(), torch.randn(FEATURES.dim, generator=g) * 0.1, torch.rand(FEATURES.dim, generator=g) + 0.5)
    text = torch.randn(2, bundle.prior.config.text_dim, generator=g)
    off = TextToMotion(steps=4, guidance=2.0, contact_rate=0.0, derive_positions=False)
    plain = generate(bundle.prior, bundle.scheduler, text, 12, 4, 2.0, torch.Generator().manual_seed(3))
    assert torch.equal(bundle.text_to_motion(text, 12, torch.Generator().manual_seed(3), off), plain)
    guided = bundle.text_to_motion(text, 12, torch.Generator().manual_seed(3), TextToMotion(steps=4, guidance=2.0))
    assert guided.shape == (2, 12, FEATURES.dim) and not torch.equal(guided, plain)
    assert TEXT_TO_MOTION.contact_rate > 0 and TEXT_TO_MOTION.contact_iterations > 0  # the shipped draw is guided
    assert TEXT_TO_MOTION.derive_positions
    from transfer.denoiser import derive_position_channels

    derived = bundle.text_to_motion(text, 12, torch.Generator().manual_seed(3),
                                    TextToMotion(steps=4, guidance=2.0, contact_rate=0.0))
    sl = FEATURES.positions  # the draw's position channels are where its rotation channels put the joints
    assert not torch.allclose(plain[..., sl], derive_position_channels(plain, bundle.mean, bundle.std)[..., sl], atol=1e-2)
    assert torch.allclose(derived, derive_position_channels(derived, bundle.mean, bundle.std), atol=1e-4)
    assert torch.equal(derived[..., :sl.start], derive_position_channels(derived, bundle.mean, bundle.std)[..., :sl.start])
    with pytest.raises(ValueError, match="need the bundle's feature mean and std"):
        MethodBundle(bundle.prior).text_to_motion(text, 12)
    assert MethodBundle(bundle.prior).text_to_motion(text, 12, settings=off).shape == (2, 12, FEATURES.dim)
    import argparse

    ap = argparse.ArgumentParser()
    TextToMotion.add_options(ap)  # the benchmarks' flags: the project's settings unless given
    assert TextToMotion.from_options(ap.parse_args([])) == TEXT_TO_MOTION
    assert TextToMotion.from_options(ap.parse_args(["--contact-rate", "0"])).contact_rate == 0.0
    assert not TextToMotion.from_options(ap.parse_args(["--no-derive-positions"])).derive_positions
    for bad in ({"steps": 0}, {"guidance": -1.0}, {"contact_rate": -0.1}, {"contact_iterations": -1}):
        with pytest.raises(ValueError, match="TextToMotion: expected"):
            TextToMotion(**bad)
