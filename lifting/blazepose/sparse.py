"""Constant-folding helpers: TFLite DENSIFY and DEQUANTIZE on numpy arrays."""

from __future__ import annotations

import numpy as np

from lifting.blazepose.tflite_model import Quantization, Sparsity


def densify(values: np.ndarray, shape: tuple[int, ...], sparsity: Sparsity) -> np.ndarray:
    """Expand TFLite's sparse storage into a dense array of ``shape``.

    ``values`` (K,) holds the stored elements in traversal order. Follows
    TFLite's FormatConverter::SparseToDense: walk the traversal dimensions
    level by level (DENSE levels enumerate ``dense_size`` children, SPARSE_CSR
    levels the children listed by ``segments``/``indices``), then map each
    traversal coordinate back to the original dimensions, block dimensions
    included (``orig = orig * block_size + block_coord``).
    """
    rank = len(shape)
    order = sparsity.traversal_order or tuple(range(rank))
    levels = sparsity.dim_metadata
    if len(levels) != len(order):
        raise ValueError(f"expected {len(order)} dimension metadata entries, got {len(levels)}")
    if len(order) - rank != len(sparsity.block_map):
        raise ValueError(
            f"expected {len(order) - rank} block_map entries for traversal order {order}, got {len(sparsity.block_map)}"
        )
    positions = np.zeros(1, np.int64)  # position of each path within its level
    coords = np.zeros((1, 0), np.int64)  # traversal coordinates of each path
    for level, meta in enumerate(levels):
        if meta.format == "DENSE":
            n = meta.dense_size
            repeats = np.full(len(positions), n, np.int64)
            child = np.tile(np.arange(n, dtype=np.int64), len(positions))
            positions = np.repeat(positions, n) * n + child
        else:
            seg, idx = meta.segments, meta.indices
            if seg is None or idx is None:
                raise ValueError(f"sparse level {level}: expected segments and indices, got none")
            starts, ends = seg[positions], seg[positions + 1]
            repeats = counts = ends - starts
            # Stored positions of the children, in order: start..end-1 for each parent.
            offsets = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
            positions = np.repeat(starts, counts) + offsets
            child = idx[positions]
        coords = np.concatenate([np.repeat(coords, repeats, axis=0), child[:, None]], axis=1)
    if len(positions) != len(values):
        raise ValueError(f"expected {len(positions)} stored values for the sparsity pattern, got {len(values)}")

    orig = np.zeros((len(positions), rank), np.int64)
    for level in range(rank):
        orig[:, order[level]] = coords[:, level]
    for level in range(rank, len(order)):
        block = order[level] - rank
        dim = sparsity.block_map[block]
        block_size = levels[level].dense_size
        orig[:, dim] = orig[:, dim] * block_size + coords[:, level]

    dense = np.zeros(shape, values.dtype)
    dense[tuple(orig.T)] = values
    return dense


def dequantize(values: np.ndarray, quantization: Quantization | None) -> np.ndarray:
    """Float32 from a DEQUANTIZE input: float16 is widened; int8/uint8/int16 use scale/zero point."""
    if values.dtype == np.float16:
        return values.astype(np.float32)
    if quantization is None:
        raise ValueError(f"expected quantization parameters to dequantize {values.dtype} values, got none")
    scale = quantization.scale.astype(np.float32)
    zero = quantization.zero_point.astype(np.float32)
    if scale.size > 1:  # per-channel
        bshape = [1] * values.ndim
        bshape[quantization.axis] = scale.size
        scale, zero = scale.reshape(bshape), zero.reshape(bshape)
    return ((values.astype(np.float32) - zero) * scale).astype(np.float32)
