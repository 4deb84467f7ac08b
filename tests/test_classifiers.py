import json
from pathlib import Path

import pytest
import torch

from evaluation.classifiers import (
    ClassifierConfig,
    ClassifierTrainConfig,
    MotionClassifier,
    default_weights,
    load_classifier,
    read_card,
    run_batched,
    train_classifier,
)
from evaluation.metrics import recognition_accuracy
from mlcore.captions import BANDAI2_CONTENTS, STYLES
from mlcore.dataset import labelled_clips
from motioncore.representation import FEATURES
from tests.synthetic_cache import write_synthetic_cache

REAL_CACHE = Path(__file__).resolve().parents[1] / "cache" / "dataset"


def test_batched_whole_clips_equal_one_at_a_time():
    torch.manual_seed(0)
    model = MotionClassifier(ClassifierConfig(channels=[8, 16], strides=[2, 2])).eval()
    clips = [torch.randn(n, FEATURES.dim) for n in (13, 40, 27)]
    batched = run_batched(model, clips, "features")
    single = torch.cat([model.features(c[None]) for c in clips])
    assert batched.shape == (3, 16) and torch.allclose(batched, single, atol=1e-5)
    assert run_batched(model, clips).shape == (3, len(BANDAI2_CONTENTS))


def test_train_classifier_tiny_run_exports_and_resumes(tmp_path):
    cache = write_synthetic_cache(tmp_path / "cache")
    cfg = ClassifierTrainConfig(target="style", channels=[8], strides=[2], batch_size=4, min_window=20, max_window=24, warmup=2)
    weights = tmp_path / "w" / "style.safetensors"
    card = train_classifier(cache, tmp_path / "run", "style", max_minutes=1, max_steps=3, config=cfg,
                            weights_path=weights, eval_every=2, progress=False)
    assert card["steps"] == 3 and card["licence"].startswith("CC BY-NC 4.0")
    assert card["test_clips"] == 2 * 2 * 6 * 2 and 0.0 <= card["test_accuracy"] <= 1.0
    assert len(card["test_confusion"]["matrix"]) == len(STYLES)
    assert json.loads(weights.with_suffix(".json").read_text()) == read_card(weights)
    model = load_classifier(weights)
    assert model.config.classes == list(STYLES) and not model.training
    train, _, _ = labelled_clips(cache, "train", "style")
    assert torch.equal(model.mean, train.mean) and torch.equal(model.std, train.std)  # stats travel in the weights
    log = (tmp_path / "run" / "log.csv").read_text().splitlines()
    assert log[0].startswith("step,") and "val_acc" in log[0] and len(log) == 4
    # resume: 2 more steps on top of the checkpoint; a changed explicit setting is refused
    card = train_classifier(cache, tmp_path / "run", "style", max_minutes=1, max_steps=5, config=cfg,
                            weights_path=weights, progress=False)
    assert card["steps"] == 5
    with pytest.raises(ValueError, match="cannot resume"):
        train_classifier(cache, tmp_path / "run", "style", max_minutes=1, max_steps=6, config=cfg, weights_path=weights,
                         explicit={"batch_size": 8}, progress=False)
    with pytest.raises(ValueError, match="target"):
        train_classifier(cache, tmp_path / "run2", "mood", max_minutes=1)


def test_load_classifier_errors(tmp_path):
    with pytest.raises(FileNotFoundError, match="no classifier weights"):
        load_classifier(tmp_path / "missing.safetensors")


@pytest.mark.parametrize("target,minimum", [("content", 0.9), ("style", 0.8)])
def test_committed_weights(target, minimum):
    path = default_weights(target)
    if not path.is_file():
        pytest.skip(f"{path.name} not trained yet (evaluation.classifiers.train_classifier)")
    assert path.stat().st_size <= 2 * 1024 * 1024
    card = read_card(path)
    assert card["test_accuracy"] >= minimum and "CC BY-NC 4.0" in card["licence"]
    model = load_classifier(path)
    assert model.config.target == target and model.config.classes == list({"content": BANDAI2_CONTENTS, "style": STYLES}[target])
    if not (REAL_CACHE / "clips.json").is_file():
        pytest.skip("needs the real dataset cache for the accuracy check")
    data, idx, labels = labelled_clips(REAL_CACHE, "test", target, originals_only=True)
    idx, labels = idx[::6], labels[::6]  # a sixth of the test originals (70 clips) keeps this fast
    acc = recognition_accuracy(model, [model.standardize(data.clip(i, normalized=False)) for i in idx], labels)
    assert acc >= minimum - 0.05
