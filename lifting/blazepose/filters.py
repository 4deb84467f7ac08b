"""One-euro filter as in MediaPipe's LandmarksSmoothingCalculator."""

from __future__ import annotations

import math

import numpy as np


class OneEuroFilter:
    """Smooths an array of values over time (all elements share the timing).

    The speed that opens the filter is measured in ``value_scale`` units per
    second, so callers pass 1/object size to make it scale-invariant
    (MediaPipe's value scaling). Defaults are MediaPipe's for the auxiliary
    pose landmarks that define the next crop: min_cutoff 0.01, beta 1.0,
    derivative cutoff 1.0.
    """

    def __init__(self, min_cutoff: float = 0.01, beta: float = 1.0, derivate_cutoff: float = 1.0):
        self.min_cutoff = min_cutoff
        self.beta = beta
        self.derivate_cutoff = derivate_cutoff
        self.reset()

    def reset(self) -> None:
        self._time: float | None = None
        self._raw: np.ndarray | None = None
        self._value: np.ndarray | None = None
        self._derivative: np.ndarray | None = None
        self._frequency = 30.0

    @staticmethod
    def _alpha(cutoff: np.ndarray | float, frequency: float) -> np.ndarray | float:
        tau = 1.0 / (2 * math.pi * cutoff)
        return 1.0 / (1.0 + tau * frequency)

    def __call__(self, value: np.ndarray, time_s: float, value_scale: float = 1.0) -> np.ndarray:
        """Filtered copy of ``value`` (any shape, fixed between calls) at ``time_s`` seconds."""
        value = np.asarray(value, dtype=float)
        if self._value is None:
            self._time, self._raw, self._value = time_s, value.copy(), value.copy()
            self._derivative = np.zeros_like(value)
            return value.copy()
        if value.shape != self._value.shape:
            raise ValueError(f"expected values of shape {self._value.shape}, got {value.shape}")
        if time_s <= self._time:  # MediaPipe passes such values through unfiltered
            return value.copy()
        self._frequency = 1.0 / (time_s - self._time)
        self._time = time_s
        speed = (value - self._raw) * value_scale * self._frequency
        self._raw = value.copy()
        a_d = self._alpha(self.derivate_cutoff, self._frequency)
        self._derivative = a_d * speed + (1 - a_d) * self._derivative
        cutoff = self.min_cutoff + self.beta * np.abs(self._derivative)
        a = self._alpha(cutoff, self._frequency)
        self._value = a * value + (1 - a) * self._value
        return self._value.copy()
