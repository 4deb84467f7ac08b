from collections import Counter
from pathlib import Path

import pytest
import torch

from evaluation.protocol import (
    format_table,
    identity_transfer,
    protocol_clips,
    run_protocol,
    select_protocol,
)
from mlcore.captions import BANDAI2_CONTENTS, STYLES
from mlcore.dataset import ClipRecord, MotionDataset
from motioncore.representation import FEATURES
from motioncore.skeleton import CANONICAL
from tests.helpers import random_classifier
from tests.synthetic_cache import write_synthetic_cache

REAL_CACHE = Path(__file__).resolve().parents[1] / "cache" / "dataset"


def _bandai2_like_records() -> list[ClipRecord]:
    """The real split's shape: 6 test originals per content x style cell, their mirrors, and train/val decoys."""
    recs = []
    for c in BANDAI2_CONTENTS:
        for s in STYLES:
            for split, n in (("test", 6), ("val", 3), ("train", 2)):
                for i in range(n):
                    for mirrored in (False, True):
                        recs.append(ClipRecord(f"{c}_{s}_{split}{i}{'_m' if mirrored else ''}", "bandai2", c, s, "", split, mirrored, 0, 40))
    recs.append(ClipRecord("b1", "bandai1", "walk", "normal", "", "test", False, 0, 40))
    return recs


def test_protocol_selection_counts_and_rules():
    recs = _bandai2_like_records()
    full = select_protocol(recs, quick=False, seed=0)
    assert len(full) == 3780  # Hu et al.'s number of transfer combinations on Bandai-2
    assert len(select_protocol(recs, quick=True, seed=0)) == 10 * 2 * 6
    for it in full:
        c, s = recs[it.content_index], recs[it.style_index]
        for r in (c, s):
            assert r.dataset == "bandai2" and r.split == "test" and not r.mirrored
        assert it.content == c.content and it.source_style == c.style
        assert s.style == it.target_style != it.source_style
    content_clips = {it.content_index for it in full}
    assert len(content_clips) == 90
    per_content = Counter(recs[i].content for i in content_clips)
    assert set(per_content.values()) == {9}
    # 9 clips per content over 7 source styles: every style once or twice
    for c in BANDAI2_CONTENTS:
        counts = Counter(recs[i].style for i in content_clips if recs[i].content == c)
        assert set(counts) == set(STYLES) and max(counts.values()) <= 2
    # each (content clip, target style) pair gets 7 distinct style examples
    pairs = Counter((it.content_index, it.target_style) for it in full)
    assert set(pairs.values()) == {7}
    assert len({(it.content_index, it.target_style, it.style_index) for it in full}) == 3780


def test_protocol_selection_is_seeded():
    recs = _bandai2_like_records()
    assert select_protocol(recs, True, seed=1) == select_protocol(recs, True, seed=1)
    assert select_protocol(recs, True, seed=1) != select_protocol(recs, True, seed=2)
    assert protocol_clips(recs) == [i for i, r in enumerate(recs) if r.split == "test" and not r.mirrored and r.dataset == "bandai2"]
    with pytest.raises(ValueError, match="no non-mirrored"):
        select_protocol([r for r in recs if r.split != "test"])


def test_run_protocol_on_a_tiny_cache(tmp_path):
    cache = write_synthetic_cache(tmp_path / "cache")
    content = random_classifier(tmp_path / "content.safetensors", "content", list(BANDAI2_CONTENTS))
    style = random_classifier(tmp_path / "style.safetensors", "style", list(STYLES))
    calls = []

    def noisy(c, s, style_label, content_label):
        calls.append((style_label, content_label))
        return c + 0.5 * torch.randn_like(c)

    rows = run_protocol({"identity": identity_transfer, "noisy": noisy}, cache, quick=False, per_content=3,
                        examples_per_style=2, content_classifier=content, style_classifier=style, progress=False)
    assert [r["method"] for r in rows] == ["real test clips (reference)", "identity", "noisy"]
    real, ident, noise = rows
    assert real["transfers"] == 2 * 2 * 6
    assert ident["transfers"] == noise["transfers"] == len(calls) == 2 * 3 * 1 * 2
    assert ident["contact_agreement"] == 1.0 and 0.0 <= noise["contact_agreement"] <= 1.0
    assert ident["fmd"] >= 0 and noise["fmd"] > ident["fmd"]
    assert {s for s, _ in calls} <= {"normal", "elderly"} and all(s != "" for s, _ in calls)
    table = format_table(rows)
    # 5 table lines, a blank, 2 by-style notes, 2 by-content notes
    assert table.count("\n") == 9 and "| identity | 12 |" in table
    assert ident["judge_toward"] == 0.0 and 0.0 <= noise["judge_toward"] <= 1.0  # the unchanged content moved nowhere
    assert set(ident["judge_by_style"]) == {s for s, _ in calls} and set(ident["by_content"]) == {"walk", "wave-left-hand"}
    for r in (ident, noise):  # per target style: the share read right, weighted back to the row's SRA and CRA
        by = r["by_style"]
        assert sum(v["n"] for v in by.values()) == r["transfers"]
        assert abs(sum(v["n"] * v["sra"] for v in by.values()) / r["transfers"] - r["sra"]) < 1e-6
        assert abs(sum(v["n"] * v["cra"] for v in by.values()) / r["transfers"] - r["cra"]) < 1e-6
        assert all(abs(sum(v["read_as"].values()) - 1) < 1e-6 for v in by.values())
        for s, v in by.items():
            assert abs(v["read_as"].get(s, 0.0) - v["sra"]) < 1e-6
    assert "- identity, by target style (CRA / SRA %; most read as; judge SRA / towards %): " in table

    def broken(c, s, style_label, content_label):
        return c[:-1]

    with pytest.raises(ValueError, match="method 'broken'"):
        run_protocol({"broken": broken}, cache, quick=True, content_classifier=content, style_classifier=style, progress=False)


@pytest.mark.skipif(not (REAL_CACHE / "clips.json").is_file(), reason="needs the real dataset cache (video2style dataset)")
def test_real_cache_protocol_shape():
    recs = MotionDataset(REAL_CACHE, split=None).records
    assert len(protocol_clips(recs)) == 420
    assert len(select_protocol(recs, quick=False)) == 3780


def test_examples_pool_limits_distinct_style_examples():
    recs = _bandai2_like_records()
    items = select_protocol(recs, quick=True, seed=0, examples_pool=1)
    assert len(items) == 120
    per_style = {}
    for it in items:
        per_style.setdefault(it.target_style, set()).add(it.style_index)
    assert set(per_style) == set(STYLES) and all(len(v) == 1 for v in per_style.values())
    full = select_protocol(recs, quick=False, seed=0, examples_pool=3)
    assert all(len({it.style_index for it in full if it.target_style == s}) == 3 for s in STYLES)
    with pytest.raises(ValueError, match="examples_pool"):
        select_protocol(recs, quick=True, examples_pool=0)


def test_unseen_protocol_takes_neutral_content_to_the_held_out_styles():
    from evaluation.protocol import HELD_OUT_STYLES, UNSEEN_FULL

    recs = _bandai2_like_records()
    items = select_protocol(recs, quick=False, seed=0, per_content=UNSEEN_FULL["per_content"], examples_pool=3,
                            sources=("normal",), targets=HELD_OUT_STYLES)
    assert {it.source_style for it in items} == {"normal"}
    assert {it.target_style for it in items} == set(HELD_OUT_STYLES)
    assert {recs[it.style_index].style for it in items} == set(HELD_OUT_STYLES)
    content_clips = {it.content_index for it in items}
    assert len(content_clips) == 10 * 6  # every neutral test clip of every content
    assert len(items) == 10 * 6 * 3 * 3  # x 3 held-out styles x 3 examples each
    with pytest.raises(ValueError, match="expected targets among"):
        select_protocol(recs, targets=("grumpy",))


def test_limb_stray_is_the_distance_off_the_content_to_example_segment():
    from evaluation.metrics import LIMBS, limb_places, limb_stray
    from motioncore.representation import encode
    from testkit.motions import random_motion

    content = encode(random_motion(seconds=2, seed=1))
    example = encode(random_motion(seconds=3, seed=2))
    assert limb_places(content).shape == (len(LIMBS), 3)
    assert torch.allclose(limb_stray(content, example, content), torch.zeros(4), atol=1e-6)
    assert torch.allclose(limb_stray(content, example, example), torch.zeros(4), atol=1e-5)
    # a result that holds every limb 0.2 m above the content's place, across a level segment, strays 0.2 m
    lifted = content.clone()
    lifted[:, FEATURES.positions] += torch.tensor([0.0, 0.2, 0.0]).repeat(CANONICAL.num_joints - 1)
    level = content.clone()
    level[:, FEATURES.positions] += torch.tensor([0.3, 0.0, 0.0]).repeat(CANONICAL.num_joints - 1)
    assert torch.allclose(limb_stray(content, level, lifted), torch.full((4,), 0.2), atol=1e-5)
    with pytest.raises(ValueError, match="expected raw features"):
        limb_stray(content[:, :10], example, content)
