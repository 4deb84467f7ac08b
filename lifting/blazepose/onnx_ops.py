"""TFLite operator → ONNX node mappings (opset 13) with layout tracking.

TFLite activations are NHWC; ONNX convolutions want NCHW. The :class:`Emitter`
keeps each 4-D activation in whichever layout its producer made and inserts a
Transpose only where a consumer needs the other one (``value(tid, layout)``).
Spatial ops produce NCHW; shape ops (RESHAPE, non-4-D CONCATENATION) work in
the native TFLite layout, so graph inputs and outputs stay NHWC.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import onnx
from onnx import helper, numpy_helper

from lifting.blazepose.tflite_model import Graph, Op

NATIVE = "native"  # TFLite's own layout (NHWC for 4-D tensors)
NCHW = "nchw"
_TO_NCHW = (0, 3, 1, 2)
_TO_NHWC = (0, 2, 3, 1)


class Emitter:
    """Accumulates ONNX nodes/initializers while walking a TFLite graph."""

    def __init__(self, graph: Graph):
        self.graph = graph
        self.nodes: list[onnx.NodeProto] = []
        self.initializers: list[onnx.TensorProto] = []
        self._values: dict[tuple[int, str], str] = {}  # (tensor id, layout) -> ONNX value name
        self._counter = 0

    # -- names and constants -------------------------------------------------
    def fresh(self, hint: str) -> str:
        self._counter += 1
        return f"{hint}_{self._counter}"

    def const(self, array: np.ndarray, hint: str = "const") -> str:
        name = self.fresh(hint)
        self.initializers.append(numpy_helper.from_array(np.ascontiguousarray(array), name))
        return name

    def node(self, op_type: str, inputs: list[str], hint: str, **attrs) -> str:
        out = self.fresh(hint)
        self.nodes.append(helper.make_node(op_type, inputs, [out], name=out, **attrs))
        return out

    # -- tensors ---------------------------------------------------------------
    def constant_data(self, tid: int) -> np.ndarray:
        t = self.graph.tensors[tid]
        if t.data is None or t.sparsity is not None:
            raise ValueError(f"tensor {t.name!r}: expected a dense constant, got a computed or sparse tensor")
        return t.data

    def is_constant(self, tid: int) -> bool:
        return self.graph.tensors[tid].data is not None

    def rank(self, tid: int) -> int:
        return len(self.graph.tensors[tid].shape)

    def layout_of(self, tid: int) -> str:
        """The layout a computed tensor was produced in (NCHW preferred when both exist)."""
        if (tid, NCHW) in self._values:
            return NCHW
        return NATIVE

    def define(self, tid: int, name: str, layout: str) -> None:
        self._values[(tid, layout)] = name

    def value(self, tid: int, layout: str) -> str:
        """ONNX value name of tensor ``tid`` in ``layout`` (constants become initializers)."""
        if (tid, layout) in self._values:
            return self._values[(tid, layout)]
        t = self.graph.tensors[tid]
        if t.data is not None:
            data = self.constant_data(tid).astype(np.float32) if t.dtype == np.float16 else self.constant_data(tid)
            if layout == NCHW:
                data = _const_to_nchw(data)
            name = self.const(data, "w")
        else:
            other = NCHW if layout == NATIVE else NATIVE
            if (tid, other) not in self._values:
                raise ValueError(f"tensor {t.name!r}: expected it to be computed before use, got no producer")
            if len(t.shape) != 4:
                raise ValueError(f"tensor {t.name!r}: expected rank 4 for a layout change, got shape {t.shape}")
            perm = _TO_NCHW if layout == NCHW else _TO_NHWC
            name = self.node("Transpose", [self._values[(tid, other)]], "transpose", perm=list(perm))
        self._values[(tid, layout)] = name
        return name


def _const_to_nchw(data: np.ndarray) -> np.ndarray:
    """Broadcastable NHWC constant (rank ≤ 4) → the matching NCHW constant."""
    expanded = data.reshape((1,) * (4 - data.ndim) + data.shape)
    return np.transpose(expanded, _TO_NCHW)


def _activation(em: Emitter, x: str, kind: str) -> str:
    if kind == "NONE":
        return x
    if kind == "RELU":
        return em.node("Relu", [x], "relu")
    if kind in ("RELU6", "RELU_N1_TO_1"):
        lo, hi = (0.0, 6.0) if kind == "RELU6" else (-1.0, 1.0)
        return em.node("Clip", [x, em.const(np.float32(lo), "lo"), em.const(np.float32(hi), "hi")], "clip")
    if kind == "TANH":
        return em.node("Tanh", [x], "tanh")
    raise ValueError(f"expected a supported fused activation (NONE, RELU, RELU6, RELU_N1_TO_1, TANH), got {kind}")


def same_padding(size: int, kernel: int, stride: int, dilation: int = 1) -> tuple[int, int]:
    """TensorFlow SAME padding (before, after) for one spatial dimension."""
    effective = (kernel - 1) * dilation + 1
    out = -(-size // stride)
    total = max((out - 1) * stride + effective - size, 0)
    return total // 2, total - total // 2


def _spatial_pads(em: Emitter, op: Op, kernel: tuple[int, int]) -> list[int]:
    if op.options["padding"] == "VALID":
        return [0, 0, 0, 0]
    _, h, w, _ = em.graph.tensors[op.inputs[0]].shape
    dil = op.options.get("dilation", (1, 1))
    (t, b), (l, r) = (
        same_padding(h, kernel[0], op.options["stride"][0], dil[0]),
        same_padding(w, kernel[1], op.options["stride"][1], dil[1]),
    )
    return [t, l, b, r]


def _conv(em: Emitter, op: Op, depthwise: bool) -> None:
    weights = em.constant_data(op.inputs[1]).astype(np.float32)  # (O,KH,KW,I) or (1,KH,KW,C*M)
    in_channels = em.graph.tensors[op.inputs[0]].shape[3]
    if depthwise:
        w = np.transpose(weights, (3, 0, 1, 2))  # (C*M, 1, KH, KW)
        group = in_channels
    else:
        w = np.transpose(weights, (0, 3, 1, 2))  # (O, I, KH, KW)
        group = 1
    kernel = (w.shape[2], w.shape[3])
    inputs = [em.value(op.inputs[0], NCHW), em.const(w, "w")]
    if len(op.inputs) > 2 and op.inputs[2] >= 0:
        inputs.append(em.const(em.constant_data(op.inputs[2]).astype(np.float32), "b"))
    y = em.node(
        "Conv",
        inputs,
        "conv",
        kernel_shape=list(kernel),
        strides=list(op.options["stride"]),
        dilations=list(op.options.get("dilation", (1, 1))),
        pads=_spatial_pads(em, op, kernel),
        group=group,
    )
    em.define(op.outputs[0], _activation(em, y, op.options["activation"]), NCHW)


def conv_2d(em: Emitter, op: Op) -> None:
    """CONV_2D: weights (O,KH,KW,I) → ONNX Conv (O,I,KH,KW); SAME → explicit TF pads."""
    _conv(em, op, depthwise=False)


def depthwise_conv_2d(em: Emitter, op: Op) -> None:
    """DEPTHWISE_CONV_2D: weights (1,KH,KW,C*M) → grouped Conv (C*M,1,KH,KW), group=C."""
    _conv(em, op, depthwise=True)


def max_pool_2d(em: Emitter, op: Op) -> None:
    """MAX_POOL_2D: ONNX MaxPool (padded cells never win, as in TFLite)."""
    kernel = op.options["filter"]
    y = em.node(
        "MaxPool",
        [em.value(op.inputs[0], NCHW)],
        "maxpool",
        kernel_shape=list(kernel),
        strides=list(op.options["stride"]),
        pads=_spatial_pads(em, op, kernel),
    )
    em.define(op.outputs[0], _activation(em, y, op.options["activation"]), NCHW)


def add(em: Emitter, op: Op) -> None:
    """ADD with broadcasting; 4-D outputs are computed in NCHW."""
    layout = NCHW if em.rank(op.outputs[0]) == 4 else NATIVE
    y = em.node("Add", [em.value(op.inputs[0], layout), em.value(op.inputs[1], layout)], "add")
    em.define(op.outputs[0], _activation(em, y, op.options.get("activation", "NONE")), layout)


def pad(em: Emitter, op: Op) -> None:
    """PAD with zeros; paddings (rank,2) constant, reordered for NCHW if 4-D."""
    paddings = em.constant_data(op.inputs[1]).astype(np.int64).reshape(-1, 2)
    layout = NCHW if len(paddings) == 4 else NATIVE
    if layout == NCHW:
        paddings = paddings[list(_TO_NCHW)]
    pads = np.concatenate([paddings[:, 0], paddings[:, 1]])
    y = em.node("Pad", [em.value(op.inputs[0], layout), em.const(pads, "pads")], "pad", mode="constant")
    em.define(op.outputs[0], y, layout)


def resize_bilinear(em: Emitter, op: Op) -> None:
    """RESIZE_BILINEAR → Resize(linear); align_corners → "align_corners",
    half_pixel_centers → "half_pixel", neither → "asymmetric" (TFLite's mappings)."""
    size = em.constant_data(op.inputs[1]).astype(np.int64).reshape(2)
    n, _, _, c = em.graph.tensors[op.inputs[0]].shape
    if op.options["align_corners"] and op.options["half_pixel_centers"]:
        raise ValueError("expected at most one of align_corners and half_pixel_centers, got both")
    mode = (
        "align_corners"
        if op.options["align_corners"]
        else "half_pixel"
        if op.options["half_pixel_centers"]
        else "asymmetric"
    )
    sizes = em.const(np.array([n, c, size[0], size[1]], np.int64), "sizes")
    y = em.node(
        "Resize",
        [em.value(op.inputs[0], NCHW), "", "", sizes],
        "resize",
        mode="linear",
        coordinate_transformation_mode=mode,
    )
    em.define(op.outputs[0], y, NCHW)


def depth_to_space(em: Emitter, op: Op) -> None:
    """DEPTH_TO_SPACE: TF's NHWC channel order equals ONNX DepthToSpace mode DCR on NCHW."""
    y = em.node(
        "DepthToSpace",
        [em.value(op.inputs[0], NCHW)],
        "d2s",
        blocksize=op.options["block_size"],
        mode="DCR",
    )
    em.define(op.outputs[0], y, NCHW)


def reshape(em: Emitter, op: Op) -> None:
    """RESHAPE in the native (NHWC) layout; target shape from the output tensor's static shape."""
    shape = em.graph.tensors[op.outputs[0]].shape
    if not shape and len(op.inputs) > 1 and em.is_constant(op.inputs[1]):
        shape = tuple(em.constant_data(op.inputs[1]).reshape(-1))
    elif not shape:
        shape = op.options.get("new_shape", ())
    y = em.node("Reshape", [em.value(op.inputs[0], NATIVE), em.const(np.array(shape, np.int64), "shape")], "reshape")
    em.define(op.outputs[0], y, NATIVE)


def concatenation(em: Emitter, op: Op) -> None:
    """CONCATENATION: 4-D tensors joined in NCHW (axis remapped), others natively."""
    rank = em.rank(op.outputs[0])
    axis = op.options["axis"] % rank
    layout = NATIVE
    if rank == 4:
        layout, axis = NCHW, _TO_NCHW.index(axis)
    y = em.node("Concat", [em.value(t, layout) for t in op.inputs], "concat", axis=axis)
    em.define(op.outputs[0], _activation(em, y, op.options.get("activation", "NONE")), layout)


def logistic(em: Emitter, op: Op) -> None:
    """LOGISTIC → Sigmoid, in whatever layout the input already has."""
    layout = em.layout_of(op.inputs[0]) if not em.is_constant(op.inputs[0]) else NATIVE
    em.define(op.outputs[0], em.node("Sigmoid", [em.value(op.inputs[0], layout)], "sigmoid"), layout)


def dequantize(em: Emitter, op: Op) -> None:
    """DEQUANTIZE of a computed float16 tensor → Cast (constant ones are folded earlier)."""
    t = em.graph.tensors[op.inputs[0]]
    if t.dtype != np.float16:
        raise ValueError(f"DEQUANTIZE of computed tensor {t.name!r}: expected float16, got {np.dtype(t.dtype).name}")
    layout = em.layout_of(op.inputs[0])
    y = em.node("Cast", [em.value(op.inputs[0], layout)], "cast", to=onnx.TensorProto.FLOAT)
    em.define(op.outputs[0], y, layout)


OP_MAPPINGS: dict[str, Callable[[Emitter, Op], None]] = {
    "CONV_2D": conv_2d,
    "DEPTHWISE_CONV_2D": depthwise_conv_2d,
    "MAX_POOL_2D": max_pool_2d,
    "ADD": add,
    "PAD": pad,
    "RESIZE_BILINEAR": resize_bilinear,
    "DEPTH_TO_SPACE": depth_to_space,
    "RESHAPE": reshape,
    "CONCATENATION": concatenation,
    "LOGISTIC": logistic,
    "DEQUANTIZE": dequantize,
}
