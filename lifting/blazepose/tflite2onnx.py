"""Convert a (float) TFLite model to ONNX opset 13.

Scope: the operators of MediaPipe's BlazePose detector and landmark models
(CONV_2D, DEPTHWISE_CONV_2D, ADD, PAD, MAX_POOL_2D, RESIZE_BILINEAR,
DEPTH_TO_SPACE, RESHAPE, CONCATENATION, LOGISTIC, DEQUANTIZE, DENSIFY).
Constant DENSIFY (sparse weights) and DEQUANTIZE (float16 weights) are folded
into float32 initializers. Graph inputs and outputs keep the TFLite names,
shapes and NHWC layout.

Command line: ``python -m lifting.blazepose.tflite2onnx model.tflite model.onnx``
"""

from __future__ import annotations

import argparse
import copy
from pathlib import Path

import numpy as np
import onnx
from onnx import helper

from lifting.blazepose.onnx_ops import NATIVE, OP_MAPPINGS, Emitter
from lifting.blazepose.sparse import densify, dequantize
from lifting.blazepose.tflite_model import Graph, read_tflite

OPSET = 13
IR_VERSION = 8  # accepted by every onnxruntime release that runs opset 13

_ONNX_TYPES = {
    np.dtype(np.float32): onnx.TensorProto.FLOAT,
    np.dtype(np.float16): onnx.TensorProto.FLOAT16,
    np.dtype(np.int32): onnx.TensorProto.INT32,
    np.dtype(np.int64): onnx.TensorProto.INT64,
    np.dtype(np.uint8): onnx.TensorProto.UINT8,
    np.dtype(np.int8): onnx.TensorProto.INT8,
}


def fold_constants(graph: Graph) -> Graph:
    """Return a copy of ``graph`` with DENSIFY/DEQUANTIZE of constants evaluated.

    Folded ops are removed; their outputs become dense float32 (DEQUANTIZE) or
    dense (DENSIFY) constant tensors.
    """
    graph = copy.copy(graph)
    graph.tensors = [copy.copy(t) for t in graph.tensors]
    kept = []
    for op in graph.ops:
        src = graph.tensors[op.inputs[0]] if op.inputs else None
        if op.kind == "DENSIFY" and src is not None and src.data is not None:
            dense = src.data if src.sparsity is None else densify(src.data, src.shape, src.sparsity)
            out = graph.tensors[op.outputs[0]]
            out.data, out.sparsity = dense.astype(src.dtype), None
        elif op.kind == "DEQUANTIZE" and src is not None and src.data is not None and src.sparsity is None:
            out = graph.tensors[op.outputs[0]]
            out.data, out.dtype = dequantize(src.data, src.quantization), np.float32
        else:
            kept.append(op)
    graph.ops = kept
    return graph


def graph_to_onnx(graph: Graph, name: str = "converted") -> onnx.ModelProto:
    """Convert a :class:`Graph` to an ONNX model (opset 13, NHWC graph inputs/outputs)."""
    graph = fold_constants(graph)
    em = Emitter(graph)
    inputs = []
    for tid in graph.inputs:
        t = graph.tensors[tid]
        em.define(tid, t.name, NATIVE)
        inputs.append(helper.make_tensor_value_info(t.name, _onnx_type(t.dtype), list(t.shape)))
    for op in graph.ops:
        if op.kind not in OP_MAPPINGS:
            if op.kind == "DENSIFY":
                raise ValueError("DENSIFY: expected a constant sparse input, got a computed tensor")
            raise ValueError(f"expected one of the supported TFLite ops {sorted(OP_MAPPINGS)}, got {op.kind}")
        OP_MAPPINGS[op.kind](em, op)
    outputs = []
    for tid in graph.outputs:
        t = graph.tensors[tid]
        em.nodes.append(helper.make_node("Identity", [em.value(tid, NATIVE)], [t.name], name=f"output_{t.name}"))
        outputs.append(helper.make_tensor_value_info(t.name, _onnx_type(t.dtype), list(t.shape)))
    onnx_graph = helper.make_graph(em.nodes, name, inputs, outputs, initializer=em.initializers)
    model = helper.make_model(
        onnx_graph,
        producer_name="video2style.tflite2onnx",
        opset_imports=[helper.make_opsetid("", OPSET)],
    )
    model.ir_version = IR_VERSION
    onnx.checker.check_model(model)
    return model


def convert_tflite(data: bytes, name: str = "converted") -> onnx.ModelProto:
    """TFLite flatbuffer bytes → ONNX model."""
    return graph_to_onnx(read_tflite(data), name=name)


def convert_file(src: str | Path, dst: str | Path) -> None:
    """Convert ``src`` (.tflite) and save the ONNX model to ``dst``."""
    src, dst = Path(src), Path(dst)
    model = convert_tflite(src.read_bytes(), name=src.stem)
    onnx.save(model, str(dst))


def _onnx_type(dtype) -> int:
    key = np.dtype(dtype)
    if key not in _ONNX_TYPES:
        raise ValueError(f"expected a graph input/output of type {sorted(map(str, _ONNX_TYPES))}, got {key}")
    return _ONNX_TYPES[key]


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description="Convert a float TFLite model to ONNX (opset 13).")
    parser.add_argument("src", type=Path, help="input .tflite file")
    parser.add_argument("dst", type=Path, help="output .onnx file")
    args = parser.parse_args(argv)
    convert_file(args.src, args.dst)


if __name__ == "__main__":
    main()
