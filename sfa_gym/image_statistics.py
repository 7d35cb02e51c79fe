"""Natural-image statistics of panoramas: how their amplitude spectrum falls with spatial
frequency, and how their local contrast is spread.

Photographs of natural scenes have a radially averaged amplitude spectrum that falls as
``1/f^alpha`` with ``alpha`` about 1 (van der Schaaf & van Hateren 1996); flat-shaded
renderings fall faster (larger ``alpha``): smooth surfaces put little energy at high
frequencies. :func:`spectrum_slope` measures ``alpha``, :func:`local_contrast` the RMS contrast
of small patches, so that a world's realism is a number, measured the same way for every world.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["Spectrum", "grey", "local_contrast", "spectrum_slope"]

# ITU-R BT.601 luma weights
_LUMA = np.array([0.299, 0.587, 0.114])


def grey(images: ArrayLike) -> NDArray[np.float64]:
    """``(N, H, W)`` luminance in [0, 1] of ``(N, H, W, 3)`` uint8 images (or ``(N, H, W)``).

    Raises:
        ValueError: not a stack of images.
    """
    x = np.asarray(images)
    if x.ndim == 4 and x.shape[-1] == 3:
        return (x.astype(np.float64) / 255.0) @ _LUMA
    if x.ndim == 3:
        return x.astype(np.float64) / (255.0 if x.dtype == np.uint8 else 1.0)
    raise ValueError(f"images must be (N, H, W, 3) or (N, H, W), got shape {x.shape}")


@dataclass(frozen=True)
class Spectrum:
    """The radially averaged amplitude spectrum and its fitted power law.

    Attributes:
        alpha: the exponent of ``A(f) ~ 1/f^alpha`` fitted over ``[f_low, f_high]``.
        frequencies: the bins' centres, cycles per pixel.
        amplitude: the mean amplitude in each bin (averaged over the images).
        f_low, f_high: the fitted range, cycles per pixel.
    """

    alpha: float
    frequencies: NDArray[np.float64]
    amplitude: NDArray[np.float64]
    f_low: float
    f_high: float


def spectrum_slope(images: ArrayLike, n_bins: int = 24, f_high: float = 0.35) -> Spectrum:
    """The radially averaged amplitude spectrum of the grey ``images`` and its slope.

    Each image loses its mean and is multiplied by a 2-d Hann window (its edges would otherwise
    add a ``1/f^2`` cross of energy); the amplitudes are averaged in ``n_bins`` log-spaced rings
    from the lowest frequency both axes resolve (two cycles over the shorter side) to
    ``f_high`` cycles per pixel (below Nyquist's 0.5, where the renderer's anti-aliasing and
    the pixel grid shape the spectrum), and ``log A`` is fitted against ``log f`` by least
    squares.

    Raises:
        ValueError: not a stack of images, images smaller than 16 pixels on a side, or a bad
            ``n_bins`` or ``f_high``.
    """
    g = grey(images)
    n, height, width = g.shape
    if min(height, width) < 16:
        raise ValueError(f"images must be at least 16 x 16 pixels, got {height} x {width}")
    if n_bins < 3:
        raise ValueError(f"n_bins must be >= 3, got {n_bins}")
    f_low = 2.0 / min(height, width)
    if not f_low < f_high <= 0.5:
        raise ValueError(f"f_high must lie in ({f_low:.3g}, 0.5] cycles per pixel, got {f_high}")
    window = np.outer(np.hanning(height), np.hanning(width))
    g = (g - g.mean(axis=(1, 2), keepdims=True)) * window
    amplitude = np.abs(np.fft.fft2(g)).mean(axis=0)
    fy, fx = np.meshgrid(np.fft.fftfreq(height), np.fft.fftfreq(width), indexing="ij")
    radius = np.hypot(fx, fy)
    edges = np.geomspace(f_low, f_high, n_bins + 1)
    which = np.digitize(radius.ravel(), edges) - 1
    inside = (which >= 0) & (which < n_bins)
    sums = np.bincount(which[inside], weights=amplitude.ravel()[inside], minlength=n_bins)
    counts = np.bincount(which[inside], minlength=n_bins)
    filled = counts > 0
    centres = np.sqrt(edges[:-1] * edges[1:])[filled]
    mean_amplitude = sums[filled] / counts[filled]
    slope = np.polyfit(np.log(centres), np.log(mean_amplitude), 1)[0]
    return Spectrum(float(-slope), centres, mean_amplitude, f_low, f_high)


def local_contrast(images: ArrayLike, patch: int = 8) -> NDArray[np.float64]:
    """The RMS contrast (standard deviation over mean luminance) of every non-overlapping
    ``patch x patch`` block of the grey ``images``, flattened; blocks darker than 1 % of full
    scale are left out (their ratio is noise).

    Raises:
        ValueError: a patch larger than the images, or below 2 pixels.
    """
    g = grey(images)
    n, height, width = g.shape
    if not 2 <= patch <= min(height, width):
        raise ValueError(f"patch must lie in [2, {min(height, width)}] pixels, got {patch}")
    rows, cols = height // patch, width // patch
    blocks = g[:, : rows * patch, : cols * patch].reshape(n, rows, patch, cols, patch)
    mean = blocks.mean(axis=(2, 4))
    std = blocks.std(axis=(2, 4))
    lit = mean > 0.01
    return std[lit] / mean[lit]
