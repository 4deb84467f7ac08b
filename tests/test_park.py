"""Park et al. 2021 stylizer: shapes, pooling, losses, save/load, inference API, a tiny training run."""
from __future__ import annotations

import json
import math

import pytest
import torch

from mlcore.checkpoints import save_model
from motioncore.representation import FEATURES
from park.infer import (
    code_from_noise,
    code_from_reference,
    generate,
    load_park,
    mix,
    pairwise_diversity,
    park_method,
    stylize_noise,
    stylize_reference,
)
from park.losses import LossWeights, d_loss, g_loss
from park.networks import (
    LEVEL1_GROUPS,
    LEVEL2_GROUPS,
    Discriminator,
    ParkConfig,
    ParkModel,
    graph_levels,
    pool,
    unpool,
)
from park.train import ParkTrainConfig, train_park

D = FEATURES.dim
SMALL = {"channels": [8, 16, 32], "window": 16}


@pytest.fixture(scope="module", autouse=True)
def one_thread():
    """Tiny nets: one thread is faster than two fighting over a busy machine."""
    n = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(n)


@pytest.fixture(scope="module")
def model(one_thread):
    torch.manual_seed(0)
    return ParkModel(ParkConfig(**SMALL)).eval()


def test_network_shapes(model):
    disc = Discriminator(model.config)
    x, y = torch.randn(3, 16, D), torch.tensor([0, 4, 6])
    s_f = model.f(torch.randn(3, model.config.latent_dim), y)
    s_e = model.e(torch.randn(3, 24, D), y)  # E takes any multiple-of-4 length
    assert s_f.shape == s_e.shape == (3, 64) and s_f.abs().max() < 1
    assert model.g(x, s_f).shape == (3, 16, D)
    assert disc(x, y).shape == (3,)
    with pytest.raises(ValueError):
        model.g(torch.randn(1, 15, D), s_f[:1])


def test_graph_pool_unpool_shapes():
    adj, groups = graph_levels()
    assert [a.shape[-1] for a in adj] == [21, 11, 5]
    assert sorted(j for g in LEVEL1_GROUPS for j in g) == list(range(21))
    assert sorted(j for g in LEVEL2_GROUPS for j in g) == list(range(11))
    x = torch.randn(2, 4, 16, 21)
    h1 = pool(x, groups[0])
    h2 = pool(h1, groups[1])
    assert h1.shape == (2, 4, 8, 11) and h2.shape == (2, 4, 4, 5)
    assert unpool(h2, groups[1], 11).shape == h1.shape and unpool(h1, groups[0], 21).shape == x.shape
    const = torch.ones(1, 1, 8, 21)  # constants survive pool -> unpool
    assert torch.allclose(unpool(pool(const, groups[0]), groups[0], 21), const)


@pytest.mark.parametrize("source", ["z", "ref"])
def test_losses_finite_with_gradients(source):
    torch.manual_seed(1)
    m = ParkModel(ParkConfig(**SMALL)).train()
    disc = Discriminator(m.config)
    x, y_org, y_trg = torch.randn(2, 16, D), torch.tensor([0, 1]), torch.tensor([2, 3])
    pair = (torch.randn(2, 16), torch.randn(2, 16)) if source == "z" else (torch.randn(2, 16, D), torch.randn(2, 16, D))
    loss, logs = d_loss(m, disc, x, y_org, y_trg, LossWeights(r1=1.0), **{source: pair[0]})
    loss.backward()
    assert torch.isfinite(loss) and all(math.isfinite(v) for v in logs.values()) and "r1" in logs
    assert all(p.grad is not None and torch.isfinite(p.grad).all() for p in disc.parameters())
    disc.zero_grad()
    loss, logs = g_loss(m, disc, x, y_org, y_trg, LossWeights(), **{source: pair})
    loss.backward()
    assert torch.isfinite(loss) and set(logs) == {"g_adv", "cyc", "id", "sty", "ds"}
    trained = [m.g, m.e] + ([m.f] if source == "z" else [])
    for net in trained:
        grads = [p.grad for p in net.parameters() if p.grad is not None]
        assert grads and all(torch.isfinite(g).all() for g in grads) and any(g.abs().sum() > 0 for g in grads)
    assert all(math.isfinite(v) for v in logs.values())


def test_save_load_round_trip(model, tmp_path):
    path = tmp_path / "park.safetensors"
    save_model(model, model.config, path, {"licence": "test"})
    loaded = load_park(path)
    c = torch.randn(40, D)
    code = code_from_noise(model, "elderly", 3)
    assert torch.equal(generate(model, c, code), generate(loaded, c, code_from_noise(loaded, "elderly", 3)))
    assert torch.equal(code_from_reference(model, c, "active"), code_from_reference(loaded, c, "active"))


def test_stylize_noise_seeds_and_root(model):
    c = torch.randn(37, D)
    a = stylize_noise(model, c, "feminine", seed=0, n_variants=3)
    b = stylize_noise(model, c, "feminine", seed=0, n_variants=3)
    other = stylize_noise(model, c, "feminine", seed=1, n_variants=1)[0]
    assert all(torch.equal(u, v) for u, v in zip(a, b))
    assert not torch.allclose(a[0], a[1]) and not torch.allclose(a[0], other)
    for out in a + [stylize_reference(model, c, torch.randn(21, D), "masculine")]:
        assert out.shape == c.shape
        for sl in (FEATURES.root_rvel, FEATURES.root_lvel):
            assert torch.equal(out[:, sl], c[:, sl])
    assert pairwise_diversity(a)["feature_l1"] > 0
    with pytest.raises(KeyError):
        stylize_noise(model, c, "sleepy")


def test_windowed_long_clip_and_method(model):
    c = torch.randn(203, D)  # many 16-frame windows, ragged end
    ca, cb = code_from_noise(model, "active", 0)[0], code_from_noise(model, "elderly", 0)[0]
    out = mix(model, c, ca, cb, 0.3)
    assert out.shape == c.shape and torch.isfinite(out).all()
    assert torch.allclose(mix(model, c, ca, cb, 0.0), generate(model, c, ca))
    method = park_method(model)
    assert method(c[:50], torch.randn(30, D), "youthful", "walk").shape == (50, D)


@pytest.mark.slow
def test_train_park_resumes(tmp_path):
    from tests.synthetic_cache import write_synthetic_cache

    data = write_synthetic_cache(tmp_path / "cache")
    cfg = ParkTrainConfig(channels=[8, 16, 32], window=32, batch_size=2)  # synthetic clips are 25-50 frames: both paths
    weights = tmp_path / "w" / "park.safetensors"
    card = train_park(data, tmp_path / "run", cfg, max_minutes=1, max_steps=2, weights_path=weights, progress=False)
    assert card["steps"] == 2 and json.loads(weights.with_suffix(".json").read_text())["licence"].startswith("CC BY-NC")
    card = train_park(data, tmp_path / "run", cfg, max_minutes=1, max_steps=3, weights_path=weights, progress=False)
    assert card["steps"] == 3
    assert (tmp_path / "run" / "log.csv").read_text().count("\n") == 4  # header + 3 rows
    m = load_park(weights)
    assert stylize_noise(m, torch.randn(20, D), "elderly")[0].shape == (20, D)
    with pytest.raises(ValueError, match="cannot resume"):
        train_park(data, tmp_path / "run", cfg, max_minutes=1, max_steps=4, weights_path=weights, progress=False,
                   explicit={"batch_size": 4})


def test_train_park_init_from_exported_weights(tmp_path):
    from tests.synthetic_cache import write_synthetic_cache

    data = write_synthetic_cache(tmp_path / "cache")
    cfg = ParkTrainConfig(channels=[8, 16, 32], window=32, batch_size=2)
    first = tmp_path / "first.safetensors"
    train_park(data, tmp_path / "run1", cfg, max_minutes=1, max_steps=1, weights_path=first, progress=False)
    # max_steps=0: nothing trained, so the export must equal the weights it started from
    tuned_cfg = ParkTrainConfig(channels=[8, 16, 32], window=32, batch_size=2, weights=LossWeights(ds=3.0))
    tuned = tmp_path / "tuned.safetensors"
    card = train_park(data, tmp_path / "run2", tuned_cfg, max_minutes=1, max_steps=0, weights_path=tuned,
                      progress=False, init_path=first)
    assert card["initialised_from"] == "fine-tuned from first.safetensors" and card["train_config"]["weights"]["ds"] == 3.0
    a, b = load_park(first).state_dict(), load_park(tuned).state_dict()
    assert all(torch.equal(a[k], b[k]) for k in a)
    with pytest.raises(ValueError, match="expected channels"):
        train_park(data, tmp_path / "run3", ParkTrainConfig(channels=[4, 8, 16], window=32, batch_size=2),
                   max_minutes=1, max_steps=0, weights_path=tmp_path / "x.safetensors", progress=False, init_path=first)
