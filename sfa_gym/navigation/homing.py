"""What panoramic homing controllers compute on two panoramas: the rotational image difference
and the visual compass it gives.

The camera's panorama columns are fixed directions of the rover: column ``c`` looks at azimuth
``heading + 2*pi*c/W`` (counter-clockwise, :mod:`sfa_gym.sim.camera.projection`), so a turn of
the rover shifts the panorama by whole columns (exactly, for whole-column turns: the views are
rendered along compass directions and resampled). A current and a goal panorama taken at
different headings are compared at their best alignment: the column shift that minimises their
RMS difference is the *visual compass* (the heading difference), the RMS difference at that
shift is the rotation-invariant *image difference* of Zeil, Hofmann & Chahl (2003), which grows
with the distance between the two places over a catchment area of metres in an open arena.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sfa_gym.geometry import wrap_angle

__all__ = [
    "STOP",
    "as_image",
    "check_band",
    "check_panorama",
    "check_speed",
    "heading_difference",
    "rotational_difference",
    "steer",
]

STOP = np.array([0.0, 0.0, 1.0], dtype=np.float32)
"""The action that ends an episode: stand still and stop."""


def check_panorama(value: Any, name: str) -> NDArray[np.uint8]:
    """``value`` as a panorama ``(H, W, 3)`` uint8, or a ValueError naming ``name``."""
    array = np.asarray(value)
    if array.dtype != np.uint8 or array.ndim != 3 or array.shape[2] != 3 or 0 in array.shape:
        raise ValueError(
            f'obs["{name}"] must be a panorama (H, W, 3) uint8, got {array.dtype} '
            f"{array.shape}: does the controller declare Capabilities(panoramas=True)?"
        )
    return array


def as_image(panorama: NDArray[np.uint8], colour: bool, blur: float = 0.0) -> NDArray[np.float64]:
    """The panorama as floats: grey levels (the mean of R, G, B) ``(H, W)``, or its colours
    ``(H, W, 3)``, low-pass filtered by a Gaussian of ``blur`` pixels (0: none; across the
    columns' wrap-around, as the panorama is periodic in azimuth).

    Blurring smooths the image difference: it keeps growing with the distance from the goal
    further out (in the open arena at 40 x 350 pixels, from 0.25 m to 2 m, it rises 2x without
    blur and about 4x with ``blur=2``) and a turn by a fraction of a column changes it less.
    """
    from scipy.ndimage import gaussian_filter

    if blur < 0:
        raise ValueError(f"blur must be >= 0 pixels, got {blur}")
    image = np.asarray(panorama, dtype=np.float64)
    image = image if colour else image.mean(axis=2)
    if blur > 0:
        sigma = (blur, blur, 0.0)[: image.ndim]
        image = gaussian_filter(image, sigma, mode=("nearest", "wrap", "nearest")[: image.ndim])
    return image


def rotational_difference(
    current: NDArray[np.float64], goal: NDArray[np.float64]
) -> tuple[float, int]:
    """The RMS difference of two images ``(H, W[, C])`` at their best column alignment, and
    that shift ``k`` (``np.roll(current, -k, axis=1)`` matches ``goal``).

    All ``W`` shifts at once through the FFT along the columns:
    ``|a - roll(b)|^2 = |a|^2 + |b|^2 - 2 * correlation``.
    """
    if current.shape != goal.shape:
        raise ValueError(f"images of different shapes: {current.shape} and {goal.shape}")
    width = current.shape[1]
    a = np.moveaxis(current, 1, -1).reshape(-1, width)
    b = np.moveaxis(goal, 1, -1).reshape(-1, width)
    spectrum = (np.fft.rfft(a, axis=1) * np.fft.rfft(b, axis=1).conj()).sum(axis=0)
    correlation = np.fft.irfft(spectrum, n=width)  # [k] = sum a[:, c + k] * b[:, c]
    squares = np.sum(a * a) + np.sum(b * b) - 2.0 * correlation
    shift = int(np.argmin(squares))
    return math.sqrt(max(float(squares[shift]), 0.0) / a.size), shift


def heading_difference(shift: int, width: int) -> float:
    """The current heading minus the goal's (rad, in ``[-pi, pi)``) from the shift ``k`` of
    :func:`rotational_difference`: a turn of ``+2*pi*k/W`` shifts a panorama by ``-k``."""
    return wrap_angle(-2.0 * math.pi * shift / width)


def check_speed(speed: float, rover: Any) -> None:
    """Raise ValueError unless ``0 < speed <= rover.v_max`` (m/s)."""
    if not 0 < speed <= rover.v_max:
        raise ValueError(f"speed must be in (0, v_max={rover.v_max}] m/s, got {speed}")


def check_band(band: tuple[float, float]) -> None:
    """Raise ValueError unless ``band`` is rows ``(from, to)``, ``0 <= from < to <= 1``."""
    if len(band) != 2 or not 0 <= band[0] < band[1] <= 1:
        raise ValueError(f"band must be (from, to) with 0 <= from < to <= 1, got {band}")


def steer(error: float, speed: float, turn_gain: float, w_max: float) -> NDArray[np.float32]:
    """The action towards a direction ``error`` rad from the heading: forward at ``speed``
    times the cosine of the error (none while it points more than 90 degrees away), turning at
    ``turn_gain`` times the error within ``+-w_max``."""
    v = speed * max(math.cos(error), 0.0)
    w = float(np.clip(turn_gain * error, -w_max, w_max))
    return np.array([v, w, -1.0], dtype=np.float32)
