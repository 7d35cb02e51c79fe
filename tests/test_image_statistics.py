"""The natural-image statistics of sfa_gym.image_statistics: the spectrum's slope is recovered
from images made with a known one, and the local contrast of a known pattern is its own."""

from __future__ import annotations

import numpy as np
import pytest

from sfa_gym.image_statistics import grey, local_contrast, spectrum_slope


def _power_law_images(alpha, shape=(60, 600), n=8, seed=0):
    """Gaussian noise whose amplitude spectrum falls as 1/f^alpha, scaled to [0, 1]."""
    rng = np.random.default_rng(seed)
    fy, fx = np.meshgrid(np.fft.fftfreq(shape[0]), np.fft.fftfreq(shape[1]), indexing="ij")
    radius = np.hypot(fx, fy)
    radius[0, 0] = 1.0
    images = []
    for _ in range(n):
        image = np.real(np.fft.ifft2(np.fft.fft2(rng.normal(size=shape)) / radius**alpha))
        images.append((image - image.min()) / (image.max() - image.min()))
    return np.array(images)


@pytest.mark.parametrize("alpha", [0.0, 1.0, 1.5])
def test_the_slope_of_a_known_power_law_is_recovered(alpha):
    assert spectrum_slope(_power_law_images(alpha)).alpha == pytest.approx(alpha, abs=0.1)


def test_colour_images_are_measured_on_their_luminance():
    images = (_power_law_images(1.0, n=4) * 255).astype(np.uint8)
    colour = np.repeat(images[..., None], 3, axis=-1)
    np.testing.assert_allclose(grey(colour), images / 255.0, atol=1e-12)
    assert spectrum_slope(colour).alpha == pytest.approx(spectrum_slope(images).alpha, abs=1e-6)


def test_the_local_contrast_of_a_known_pattern():
    # 8 x 8 blocks of alternating 0.25 and 0.75 columns: mean 0.5, standard deviation 0.25
    stripes = np.tile([0.25, 0.75], (16, 16))[None]
    np.testing.assert_allclose(local_contrast(stripes), 0.5)
    # a flat image has none, and black blocks are left out
    assert np.all(local_contrast(np.full((1, 16, 32), 0.5)) == 0.0)
    assert local_contrast(np.zeros((1, 16, 32))).size == 0


def test_bad_inputs_are_named():
    with pytest.raises(ValueError, match=r"must be \(N, H, W, 3\) or \(N, H, W\), got shape"):
        grey(np.zeros((8, 8)))
    with pytest.raises(ValueError, match="at least 16 x 16 pixels, got 8 x 64"):
        spectrum_slope(np.zeros((1, 8, 64)))
    with pytest.raises(ValueError, match="f_high must lie in"):
        spectrum_slope(np.zeros((1, 32, 64)), f_high=0.9)
    with pytest.raises(ValueError, match=r"patch must lie in \[2, 16\] pixels, got 32"):
        local_contrast(np.zeros((1, 16, 64)), patch=32)
