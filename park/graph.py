"""Spatial-temporal graph convolution (ST-GCN, Yan et al. 2018) on the canonical skeleton.

The layer of Park et al.'s stylizer (:mod:`park.networks`), shared with the motion classifiers
(``evaluation/classifiers.py``).

Graph and partitions (Park et al. 2021 §5.1): nodes are the canonical joints, edges the bones of
:data:`CANONICAL`. The 1-hop neighbour set of node ``i`` is split into three subsets by the
*spatial configuration* partition: label 0 = the node itself, 1 = neighbours nearer the root
(Hips) than ``i``, 2 = neighbours farther from the root. Each subset has its own weights and is
averaged over its members (Park's normaliser ``Z_ij`` = the subset's cardinality), so
``A[k, i, j] = 1 / |{j' : label(i, j') = k}|`` for every ``j`` with ``label(i, j) = k``.

Input layout (:func:`features_to_graph`), ``GRAPH_CHANNELS = 10`` channels per joint, taken from
the :data:`FEATURES` slices of the (normalised) feature vector:

- channels 0-2 ``position``: the joint's root-relative position in the facing frame; for the Hips,
  which has none, ``(planar velocity x, root height, planar velocity z)`` (the facing-frame root
  velocity sits in the horizontal slots, the height in the vertical one);
- channels 3-8 ``rotation``: the joint's local 6D rotation (the Hips' relative to the facing direction);
- channel 9 ``extra``: the root yaw velocity on the Hips, the contact flag on the four contact
  joints (``CANONICAL.feet``), 0 elsewhere.

Every feature value lands in exactly one slot, so :func:`graph_to_features` inverts it exactly.
"""
from __future__ import annotations

from collections import deque

import torch
from torch import nn

from motioncore.representation import FeatureSpec
from motioncore.skeleton import CANONICAL, CanonicalSpec

GRAPH_CHANNELS = 10
NUM_PARTITIONS = 3


# ----------------------------------------------------------------------------------------- graph

def skeleton_edges(spec: CanonicalSpec = CANONICAL) -> list[tuple[int, int]]:
    """Bones as ``(parent, child)`` node pairs."""
    return [(p, c) for c, p in enumerate(spec.skeleton.parents) if p >= 0]


def hop_distance(num_nodes: int, edges: list[tuple[int, int]], root: int) -> list[int]:
    """Edge hops from ``root`` to every node (BFS); raises if the graph is disconnected."""
    nbrs: list[list[int]] = [[] for _ in range(num_nodes)]
    for a, b in edges:
        nbrs[a].append(b)
        nbrs[b].append(a)
    dist = [-1] * num_nodes
    dist[root] = 0
    queue = deque([root])
    while queue:
        i = queue.popleft()
        for j in nbrs[i]:
            if dist[j] < 0:
                dist[j] = dist[i] + 1
                queue.append(j)
    if min(dist) < 0:
        raise ValueError(f"hop_distance: nodes {[i for i, d in enumerate(dist) if d < 0]} are not connected to the root")
    return dist


def partition_labels(num_nodes: int, edges: list[tuple[int, int]], root: int = 0) -> torch.Tensor:
    """``(V, V)`` int64: label of node ``j`` in node ``i``'s neighbour set, -1 if not a neighbour.

    0 = ``i`` itself, 1 = nearer the root than ``i``, 2 = farther. Neighbours at the same hop
    distance (only in graphs with cycles) go to subset 0, as in Yan et al.'s code.
    """
    dist = hop_distance(num_nodes, edges, root)
    labels = torch.full((num_nodes, num_nodes), -1, dtype=torch.long)
    for i in range(num_nodes):
        labels[i, i] = 0
    for a, b in edges:
        for i, j in ((a, b), (b, a)):
            labels[i, j] = 1 if dist[j] < dist[i] else 2 if dist[j] > dist[i] else 0
    return labels


def partition_adjacency(labels: torch.Tensor) -> torch.Tensor:
    """``(3, V, V)`` float: ``A[k, i, j] = 1/Z`` where ``Z`` counts node ``i``'s neighbours with label ``k``."""
    a = torch.stack([(labels == k).float() for k in range(NUM_PARTITIONS)])
    return a / a.sum(-1, keepdim=True).clamp_min(1.0)


def canonical_labels(spec: CanonicalSpec = CANONICAL) -> torch.Tensor:
    """:func:`partition_labels` on the canonical skeleton, rooted at its root joint (Hips)."""
    return partition_labels(spec.num_joints, skeleton_edges(spec), root=spec.skeleton.parents.index(-1))


def canonical_adjacency(spec: CanonicalSpec = CANONICAL) -> torch.Tensor:
    """``(3, J, J)`` spatial-partition adjacency of the canonical skeleton."""
    return partition_adjacency(canonical_labels(spec))


def pooled_graph(num_nodes: int, edges: list[tuple[int, int]], groups: list[list[int]]) -> list[tuple[int, int]]:
    """Edges of the coarser graph whose node ``g`` averages the nodes ``groups[g]`` (Park §5.2).

    Two groups are joined when any of their members are. Use with :func:`graph_pool`.
    """
    owner = [-1] * num_nodes
    for g, members in enumerate(groups):
        for m in members:
            if owner[m] >= 0:
                raise ValueError(f"pooled_graph: node {m} is in groups {owner[m]} and {g}")
            owner[m] = g
    if min(owner) < 0:
        raise ValueError(f"pooled_graph: nodes {[i for i, o in enumerate(owner) if o < 0]} are in no group")
    out = {tuple(sorted((owner[a], owner[b]))) for a, b in edges if owner[a] != owner[b]}
    return sorted(out)


def graph_pool(x: torch.Tensor, groups: list[list[int]]) -> torch.Tensor:
    """``(B, C, T, V) -> (B, C, T, len(groups))``: the mean over each group's nodes."""
    return torch.stack([x[..., g].mean(-1) for g in groups], dim=-1)


def graph_unpool(x: torch.Tensor, groups: list[list[int]], num_nodes: int) -> torch.Tensor:
    """``(B, C, T, G) -> (B, C, T, V)``: each node takes its group's value."""
    index = torch.empty(num_nodes, dtype=torch.long)
    for g, members in enumerate(groups):
        index[members] = g
    return x[..., index.to(x.device)]


# ------------------------------------------------------------------------------ input conversion

def _extra_nodes(spec: CanonicalSpec) -> list[int]:
    return list(spec.feet)


def features_to_graph(x: torch.Tensor, spec: CanonicalSpec = CANONICAL) -> torch.Tensor:
    """Features ``(B, T, D)`` -> per-joint channels ``(B, GRAPH_CHANNELS, T, J)`` (layout in the module doc)."""
    fs = FeatureSpec(spec.num_joints)
    if x.shape[-1] != fs.dim:
        raise ValueError(f"features_to_graph: expected (B, T, {fs.dim}), got {tuple(x.shape)}")
    b, t, _ = x.shape
    j = spec.num_joints
    out = x.new_zeros(b, t, j, GRAPH_CHANNELS)
    out[:, :, 1:, 0:3] = x[..., fs.positions].unflatten(-1, (j - 1, 3))
    out[:, :, 0, 0] = x[..., fs.root_lvel.start]
    out[:, :, 0, 1] = x[..., fs.root_height.start]
    out[:, :, 0, 2] = x[..., fs.root_lvel.start + 1]
    out[:, :, :, 3:9] = x[..., fs.rotations].unflatten(-1, (j, 6))
    out[:, :, 0, 9] = x[..., fs.root_rvel.start]
    out[:, :, _extra_nodes(spec), 9] = x[..., fs.contacts]
    return out.permute(0, 3, 1, 2).contiguous()


def graph_to_features(g: torch.Tensor, spec: CanonicalSpec = CANONICAL) -> torch.Tensor:
    """Inverse of :func:`features_to_graph`: ``(B, GRAPH_CHANNELS, T, J) -> (B, T, D)``; unused slots are dropped."""
    fs = FeatureSpec(spec.num_joints)
    b, c, t, j = g.shape
    if c != GRAPH_CHANNELS or j != spec.num_joints:
        raise ValueError(f"graph_to_features: expected (B, {GRAPH_CHANNELS}, T, {spec.num_joints}), got {tuple(g.shape)}")
    n = g.permute(0, 2, 3, 1)  # (B, T, J, C)
    x = g.new_zeros(b, t, fs.dim)
    x[..., fs.root_rvel.start] = n[:, :, 0, 9]
    x[..., fs.root_lvel.start] = n[:, :, 0, 0]
    x[..., fs.root_lvel.start + 1] = n[:, :, 0, 2]
    x[..., fs.root_height.start] = n[:, :, 0, 1]
    x[..., fs.positions] = n[:, :, 1:, 0:3].flatten(2)
    x[..., fs.rotations] = n[:, :, :, 3:9].flatten(2)
    x[..., fs.contacts] = n[:, :, _extra_nodes(spec), 9]
    return x


# ------------------------------------------------------------------------------------- layers

class GraphConv(nn.Module):
    """Spatial graph convolution: ``out[i] = sum_k sum_j A[k, i, j] W_k x[j]`` over ``(B, C, T, V)``.

    ``edge_importance`` adds Yan et al.'s learnable per-edge mask (initialised to 1).
    """

    def __init__(self, in_channels: int, out_channels: int, adjacency: torch.Tensor, edge_importance: bool = False):
        super().__init__()
        self.register_buffer("adjacency", adjacency.clone().float(), persistent=False)
        self.k = adjacency.shape[0]
        self.out_channels = out_channels
        self.proj = nn.Conv2d(in_channels, out_channels * self.k, kernel_size=1)
        self.importance = nn.Parameter(torch.ones_like(adjacency)) if edge_importance else None

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        b, _, t, v = x.shape
        h = self.proj(x).view(b, self.k, self.out_channels, t, v)
        a = self.adjacency if self.importance is None else self.adjacency * self.importance
        return torch.einsum("bkctj,kij->bcti", h, a)


def _norm(kind: str, channels: int) -> nn.Module:
    if kind == "batch":
        return nn.BatchNorm2d(channels)
    if kind == "instance":  # per sample and channel over (T, V); affine-free so AdaIN can supply scale and shift
        return nn.InstanceNorm2d(channels, affine=False)
    if kind == "none":
        return nn.Identity()
    raise ValueError(f"STGCNBlock: unknown norm {kind!r}; expected 'batch', 'instance' or 'none'")


def _masked(x: torch.Tensor, mask: torch.Tensor | None) -> torch.Tensor:
    return x if mask is None else x * mask


def downsample_mask(mask: torch.Tensor, stride: int) -> torch.Tensor:
    """Frame mask ``(B, 1, T, 1)`` after a temporal conv with ``stride`` and 'same' padding."""
    return mask[:, :, ::stride] if stride > 1 else mask


class STGCNBlock(nn.Module):
    """Graph conv -> norm -> act -> temporal conv (``kernel x 1``, ``stride``) -> norm -> (+ AdaIN) + residual -> act.

    ``forward(x, mask=None, style=None)``: ``x (B, C, T, V)``; ``mask (B, 1, T, 1)`` (1 = valid frame)
    zeroes padded frames before every temporal conv and on the output, so a zero-padded batch gives
    each clip the same result as running it alone (with ``norm='batch'`` in eval mode or ``'none'``).
    ``style (B, 2 * out_channels)`` is an AdaIN hook: ``h * (1 + scale) + shift`` after the second norm.
    """

    def __init__(self, in_channels: int, out_channels: int, adjacency: torch.Tensor, temporal_kernel: int = 9,
                 stride: int = 1, residual: bool = True, norm: str = "batch", dropout: float = 0.0,
                 activation: str = "relu", edge_importance: bool = False):
        super().__init__()
        if temporal_kernel % 2 != 1:
            raise ValueError(f"STGCNBlock: expected an odd temporal kernel, got {temporal_kernel}")
        self.stride = stride
        self.gcn = GraphConv(in_channels, out_channels, adjacency, edge_importance)
        self.norm1 = _norm(norm, out_channels)
        self.tcn = nn.Conv2d(out_channels, out_channels, (temporal_kernel, 1), (stride, 1), (temporal_kernel // 2, 0))
        self.norm2 = _norm(norm, out_channels)
        self.dropout = nn.Dropout(dropout)
        self.act = nn.LeakyReLU(0.2) if activation == "leaky_relu" else nn.ReLU()
        if not residual:
            self.residual = None
        elif in_channels == out_channels and stride == 1:
            self.residual = nn.Identity()
        else:
            self.residual = nn.Sequential(nn.Conv2d(in_channels, out_channels, 1, (stride, 1)), _norm(norm, out_channels))

    def forward(self, x: torch.Tensor, mask: torch.Tensor | None = None, style: torch.Tensor | None = None) -> torch.Tensor:
        x = _masked(x, mask)
        h = self.act(self.norm1(self.gcn(x)))
        h = self.norm2(self.tcn(self.dropout(_masked(h, mask))))
        if style is not None:
            scale, shift = style[:, :, None, None].chunk(2, dim=1)
            h = h * (1 + scale) + shift
        if self.residual is not None:
            h = h + self.residual(x)
        out_mask = None if mask is None else downsample_mask(mask, self.stride)
        return _masked(self.act(h), out_mask)


def masked_mean(h: torch.Tensor, mask: torch.Tensor | None) -> torch.Tensor:
    """Global average over time and joints of ``(B, C, T, V)`` counting only valid frames -> ``(B, C)``."""
    if mask is None:
        return h.mean(dim=(2, 3))
    m = mask.to(h.dtype)
    return (h * m).sum(dim=(2, 3)) / (m.sum(dim=(2, 3)) * h.shape[-1]).clamp_min(1.0)


def valid_to_mask(valid: torch.Tensor | None, frames: int) -> torch.Tensor | None:
    """``valid (B, T)`` bool -> ``(B, 1, T, 1)`` float, or None."""
    if valid is None:
        return None
    if valid.shape[-1] != frames:
        raise ValueError(f"valid: expected (B, {frames}), got {tuple(valid.shape)}")
    return valid[:, None, :, None].float()


__all__ = [
    "GRAPH_CHANNELS",
    "NUM_PARTITIONS",
    "GraphConv",
    "STGCNBlock",
    "canonical_adjacency",
    "canonical_labels",
    "downsample_mask",
    "features_to_graph",
    "graph_pool",
    "graph_to_features",
    "graph_unpool",
    "hop_distance",
    "masked_mean",
    "partition_adjacency",
    "partition_labels",
    "pooled_graph",
    "skeleton_edges",
    "valid_to_mask",
]
