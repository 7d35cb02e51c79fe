"""Input normalisations that remove known changing variables of outdoor appearance.

Outdoors the light changes with the sun, the clouds and the camera's exposure, on time scales
like the robot's own movement, so slow features pick it up (Metka et al. 2013, outlook ii). Both
normalisations act on each panorama alone, keep the ``(H, W, 3)`` uint8 layout every feature
method reads, and commute with the simulated rotation (a circular shift of the columns), so
rotation shortcuts stay exact:

- ``"grey_world"``: each colour channel scaled so that its mean over the panorama is mid-grey:
  removes a global gain and a colour cast (auto-exposure, the sun's colour, overcast).
- ``"log_gradient"``: differences of the log intensity between neighbouring pixels, along the
  width (circular) in channel 0, down the height in channel 1, and the log chromaticity
  (red against blue) in channel 2: a multiplicative change of the light cancels; edges stay.
"""

from __future__ import annotations

from typing import Literal, get_args

import numpy as np
from numpy.typing import NDArray

__all__ = ["NORMALISATIONS", "Normalisation", "normalise_panoramas"]

Normalisation = Literal["none", "grey_world", "log_gradient"]
NORMALISATIONS: tuple[str, ...] = get_args(Normalisation)

_GREY = 110.0  # target channel mean of grey_world, in grey levels
_LOG_SCALE = 64.0  # grey levels per unit of log intensity in log_gradient


def normalise_panoramas(
    panoramas: NDArray[np.uint8], mode: Normalisation, chunk: int = 512
) -> NDArray[np.uint8]:
    """``panoramas (L, H, W, 3)`` uint8 normalised by ``mode`` (see the module docstring), the
    same shape and dtype; ``"none"`` returns the input unchanged."""
    if mode not in NORMALISATIONS:
        raise ValueError(f"normalisation must be one of {list(NORMALISATIONS)}, got {mode!r}")
    panoramas = np.asarray(panoramas)
    if panoramas.ndim != 4 or panoramas.shape[3] != 3 or panoramas.dtype != np.uint8:
        raise ValueError(
            f"panoramas must be (L, H, W, 3) uint8, got {panoramas.shape} {panoramas.dtype}"
        )
    if mode == "none":
        return panoramas
    out = np.empty_like(panoramas)
    for i in range(0, len(panoramas), chunk):
        block = panoramas[i : i + chunk].astype(np.float32)
        out[i : i + chunk] = _grey_world(block) if mode == "grey_world" else _log_gradient(block)
    return out


def _to_uint8(values: NDArray[np.float32]) -> NDArray[np.uint8]:
    return np.clip(np.rint(values), 0, 255).astype(np.uint8)


def _grey_world(block: NDArray[np.float32]) -> NDArray[np.uint8]:
    means = block.mean(axis=(1, 2), keepdims=True)
    return _to_uint8(block * (_GREY / np.maximum(means, 1.0)))


def _log_gradient(block: NDArray[np.float32]) -> NDArray[np.uint8]:
    # +1: black pixels (the mirror's rim, deep shadow) have a finite log
    log = np.log(block + 1.0)
    intensity = log.mean(axis=3)
    along = intensity - np.roll(intensity, 1, axis=2)  # periodic in the width
    down = np.zeros_like(intensity)
    down[:, 1:] = intensity[:, 1:] - intensity[:, :-1]
    chroma = log[..., 0] - log[..., 2]
    stacked = np.stack([along, down, chroma], axis=3)
    return _to_uint8(128.0 + _LOG_SCALE * stacked)
