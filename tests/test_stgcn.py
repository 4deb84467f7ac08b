import pytest
import torch

from motioncore.representation import FEATURES
from motioncore.skeleton import CANONICAL
from park.graph import (
    GRAPH_CHANNELS,
    GraphConv,
    STGCNBlock,
    canonical_adjacency,
    canonical_labels,
    features_to_graph,
    graph_pool,
    graph_to_features,
    graph_unpool,
    partition_labels,
    pooled_graph,
)

NAMES = CANONICAL.skeleton.names


def _labels_of(joint: str) -> dict[str, int]:
    labels = canonical_labels()
    i = NAMES.index(joint)
    return {NAMES[j]: int(labels[i, j]) for j in range(len(NAMES)) if labels[i, j] >= 0}


def test_partition_labels_on_the_canonical_skeleton():
    assert _labels_of("Spine") == {"Spine": 0, "Hips": 1, "Chest": 2}
    assert _labels_of("Hips") == {"Hips": 0, "Spine": 2, "UpperLeg_L": 2, "UpperLeg_R": 2}
    assert _labels_of("Chest") == {"Chest": 0, "Spine": 1, "Neck": 2, "Shoulder_L": 2, "Shoulder_R": 2}
    assert _labels_of("Hand_R") == {"Hand_R": 0, "LowerArm_R": 1}
    assert _labels_of("Foot_L") == {"Foot_L": 0, "LowerLeg_L": 1, "Toes_L": 2}
    labels = canonical_labels()
    # nearer-the-root and farther-from-the-root are each other's mirror image; 20 bones, 21 self-loops
    assert torch.equal(labels == 1, (labels == 2).T)
    assert int((labels == 1).sum()) == 20 and int((labels == 0).sum()) == 21


def test_partition_adjacency_averages_each_subset():
    a = canonical_adjacency()
    assert a.shape == (3, 21, 21)
    chest, spine = NAMES.index("Chest"), NAMES.index("Spine")
    assert a[0, chest, chest] == 1 and a[1, chest, spine] == 1
    assert torch.allclose(a[2, chest, [NAMES.index(n) for n in ("Neck", "Shoulder_L", "Shoulder_R")]], torch.full((3,), 1 / 3))
    rows = a.sum(-1)  # 1 where the subset is non-empty, else 0
    assert torch.all(((rows - 1).abs() < 1e-6) | (rows == 0))
    assert rows[1, NAMES.index("Hips")] == 0 and rows[2, NAMES.index("Head")] == 0


def test_partition_labels_generic_graph_and_errors():
    # a path 2 - 0 - 1 rooted at 0, with a triangle-closing edge 1 - 2 (same depth -> subset 0)
    labels = partition_labels(3, [(0, 1), (0, 2), (1, 2)], root=0)
    assert labels.tolist() == [[0, 2, 2], [1, 0, 0], [1, 0, 0]]
    with pytest.raises(ValueError, match="not connected"):
        partition_labels(3, [(0, 1)], root=0)


def test_feature_graph_layout_round_trip():
    x = torch.randn(2, 7, FEATURES.dim)
    g = features_to_graph(x)
    assert g.shape == (2, GRAPH_CHANNELS, 7, 21)
    hips, spine, toes = NAMES.index("Hips"), NAMES.index("Spine"), NAMES.index("Toes_R")
    assert torch.equal(g[:, 1, :, hips], x[..., FEATURES.root_height.start])
    assert torch.equal(g[:, 0, :, hips], x[..., FEATURES.root_lvel.start])
    assert torch.equal(g[:, 9, :, hips], x[..., FEATURES.root_rvel.start])
    assert torch.equal(g[:, 0:3, :, spine].permute(0, 2, 1), x[..., FEATURES.positions.start:FEATURES.positions.start + 3])
    assert torch.equal(g[:, 9, :, toes], x[..., FEATURES.contacts.start + CANONICAL.feet.index(toes)])
    assert torch.equal(g[:, 9, :, spine], torch.zeros(2, 7))
    assert torch.equal(graph_to_features(g), x)


def test_graph_conv_matches_the_definition():
    torch.manual_seed(0)
    a = canonical_adjacency()
    conv = GraphConv(4, 5, a)
    x = torch.randn(1, 4, 3, 21)
    out = conv(x)
    w = conv.proj.weight[:, :, 0, 0].view(3, 5, 4)
    bias = conv.proj.bias.view(3, 5)
    i = NAMES.index("Chest")
    expect = sum(a[k, i, j] * (w[k] @ x[0, :, :, j] + bias[k][:, None]) for k in range(3) for j in range(21))
    assert torch.allclose(out[0, :, :, i], expect, atol=1e-5)


def test_masked_batch_equals_clips_one_at_a_time():
    torch.manual_seed(0)
    a = canonical_adjacency()
    blocks = torch.nn.ModuleList([STGCNBlock(GRAPH_CHANNELS, 8, a, stride=2, residual=False),
                                  STGCNBlock(8, 8, a, temporal_kernel=5)]).eval()

    def run(x, mask):
        for b in blocks:
            x = b(x, mask)
            mask = None if mask is None else mask[:, :, ::b.stride]
        return x

    short, long_ = torch.randn(1, GRAPH_CHANNELS, 13, 21), torch.randn(1, GRAPH_CHANNELS, 30, 21)
    batch = torch.zeros(2, GRAPH_CHANNELS, 30, 21)
    batch[0, :, :13], batch[1] = short[0], long_[0]
    mask = torch.zeros(2, 1, 30, 1)
    mask[0, :, :13], mask[1] = 1, 1
    out = run(batch, mask)
    assert torch.allclose(out[0, :, :7], run(short, None)[0], atol=1e-5)  # ceil(13 / 2) frames
    assert torch.allclose(out[1], run(long_, None)[0], atol=1e-5)
    assert torch.all(out[0, :, 7:] == 0)


def test_adain_hook_and_instance_norm():
    a = canonical_adjacency()
    block = STGCNBlock(3, 6, a, norm="instance", activation="leaky_relu")
    x = torch.randn(2, 3, 10, 21)
    assert torch.allclose(block(x, style=torch.zeros(2, 12)), block(x))
    assert not torch.allclose(block(x, style=torch.randn(2, 12)), block(x))
    with pytest.raises(ValueError, match="unknown norm"):
        STGCNBlock(3, 6, a, norm="layer")


def test_pooling_helpers():
    groups = [[0, 1, 2], [3, 4], [5, 6, 7, 8]]
    edges = [(0, 1), (1, 2), (2, 3), (3, 4), (2, 5), (5, 6), (6, 7), (7, 8)]
    assert pooled_graph(9, edges, groups) == [(0, 1), (0, 2)]
    x = torch.arange(9.0).view(1, 1, 1, 9)
    p = graph_pool(x, groups)
    assert p.flatten().tolist() == [1.0, 3.5, 6.5]
    assert graph_unpool(p, groups, 9).flatten().tolist() == [1.0, 1.0, 1.0, 3.5, 3.5, 6.5, 6.5, 6.5, 6.5]
    with pytest.raises(ValueError, match="in no group"):
        pooled_graph(9, edges, groups[:2])
