"""Shared fixtures: the BlazePose models, obtained once per session into the user cache."""

from __future__ import annotations

import pytest

from lifting.blazepose.assets import ModelUnavailableError, ensure_models


@pytest.fixture(scope="session")
def blazepose_models():
    """``{"pose_detection": Path, "pose_landmark_full": Path}`` or skip (no wheel, no registry)."""
    try:
        return ensure_models()
    except ModelUnavailableError as exc:
        reason = " | ".join(line.strip() for line in str(exc).splitlines()[:3])
        pytest.skip(f"BlazePose models unavailable (no PyPI access, no local wheel): {reason}")


@pytest.fixture(scope="session")
def tracker(blazepose_models):
    from lifting.blazepose.tracker import PoseTracker

    return PoseTracker(blazepose_models)
