"""Record reference outputs of the original .tflite BlazePose models.

Run from the repository root (needs ai-edge-litert and PyPI access or
$VIDEO2STYLE_MEDIAPIPE_WHEEL):

    python -m tests.lifting.record_reference

Writes tests/lifting/data/blazepose_reference.npz: the two model inputs
(uint8 images made from a synthetic humanoid) and a small set of outputs.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import cv2
import numpy as np
from ai_edge_litert.interpreter import Interpreter

from lifting.blazepose.assets import (
    MODELS,
    WHEEL_ENV,
    download_wheel,
    read_wheel_member,
)
from lifting.blazepose.detector import decode, weighted_nms
from lifting.blazepose.geometry import (
    crop,
    crop_to_image,
    letterbox_roi,
    roi_from_alignment_points,
)
from testkit.synthetic_blazepose import humanoid_frame

OUT = Path(__file__).parent / "data" / "blazepose_reference.npz"
TOP_K = 8


def run_tflite(content: bytes, x: np.ndarray) -> dict[str, np.ndarray]:
    interpreter = Interpreter(model_content=content)
    interpreter.allocate_tensors()
    interpreter.set_tensor(interpreter.get_input_details()[0]["index"], x)
    interpreter.invoke()
    return {d["name"]: interpreter.get_tensor(d["index"]) for d in interpreter.get_output_details()}


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        wheel = Path(os.environ[WHEEL_ENV]) if os.environ.get(WHEEL_ENV) else download_wheel(Path(tmp))
        models = {name: read_wheel_member(wheel, member, sha) for name, (member, sha) in MODELS.items()}

    frame = cv2.cvtColor(humanoid_frame(1280, 720, phase=0.6, seed=3), cv2.COLOR_BGR2RGB)
    det_roi = letterbox_roi(1280, 720)
    det_input = crop(frame, det_roi, 224, border="zero")
    det = run_tflite(models["pose_detection"], det_input.astype(np.float32)[None] * (2.0 / 255.0) - 1.0)
    logits, boxes = det["Identity_1"][0, :, 0], det["Identity"][0]
    top = np.argsort(-logits, kind="stable")[:TOP_K]

    score, _, kps = weighted_nms(*decode(boxes, logits), min_score=0.5)[0]
    kps = crop_to_image(kps * 224, det_roi, 224)
    lm_input = crop(frame, roi_from_alignment_points(kps[0], kps[1]), 256)
    lm = run_tflite(models["pose_landmark_full"], lm_input.astype(np.float32)[None] / 255.0)

    np.savez_compressed(
        OUT,
        det_input=det_input,
        det_top_index=top,
        det_top_logit=logits[top],
        det_top_boxes=boxes[top],
        lm_input=lm_input,
        lm_flag=lm["Identity_1"][0],
        lm_landmarks=lm["Identity"][0],
        lm_world=lm["Identity_4"][0],
        lm_heatmap_max=lm["Identity_3"][0].max(axis=(0, 1)),
    )
    print(
        f"wrote {OUT} ({OUT.stat().st_size} bytes); detection score {score:.3f}, pose flag {lm['Identity_1'][0, 0]:.3f}"
    )


if __name__ == "__main__":
    main()
