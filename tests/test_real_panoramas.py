"""The image-statistics study's real panoramas: an equirectangular HDR photograph is cut to the
cylindrical camera's elevation band, shrunk to its size and exposed like its auto-exposure."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from eval.studies.image_statistics import REAL_HEADINGS, _exposed, _real
from sfa_gym.sim.camera import PanoramaSpec
from sfa_gym.sim.camera.sensor import SensorSpec


def test_the_exposure_puts_the_mean_grey_level_at_the_target_and_clips_highlights():
    rng = np.random.default_rng(0)
    radiance = rng.lognormal(mean=3.0, sigma=1.5, size=(30, 40, 3))  # any absolute scale
    for target in (60.0, 100.0, 160.0):
        image = _exposed(radiance, target)
        assert image.dtype == np.uint8
        assert abs(image.mean() - target) < 1.0
    bright = _exposed(radiance, 100.0)
    assert (bright == 255).any() and (bright < 255).any()  # a sun clips, the rest does not
    # the same picture at another absolute scale is exposed the same
    assert np.array_equal(_exposed(radiance * 1000.0, 100.0), bright)


def test_a_real_panorama_is_cut_to_the_camera_band_and_shrunk(tmp_path):
    spec = PanoramaSpec.paper_outdoor()
    rows, cols = 360, 720  # half a degree per pixel
    elevation = 90.0 - (np.arange(rows) + 0.5) / 2.0  # degrees, top row at the zenith
    # bright outside the camera's band, dark inside it, with a vertical stripe at one heading
    radiance = np.where(np.abs(elevation) < spec.vfov_deg / 2, 0.05, 5.0)[:, None, None]
    radiance = np.broadcast_to(radiance, (rows, cols, 3)).copy()
    radiance[:, :36] *= 4.0  # the first 18 degrees of azimuth
    path = tmp_path / "place.hdr"
    assert cv2.imwrite(str(path), radiance.astype(np.float32))

    views = _real(path)
    assert views.shape == (REAL_HEADINGS, spec.height, spec.width, 3)
    first = views[0].astype(float).mean(axis=(0, 2))
    # no row of the bright sky or ground in the band: every row sees the same stripe and floor
    assert np.ptp(views[0].astype(float).mean(axis=(1, 2))) < 1.0
    assert first[:30].min() > first[30:].max() + 20  # the stripe's 18 degrees are 30 columns
    # each view turns the same panorama by a twelfth
    step = spec.width // REAL_HEADINGS
    assert views[1].astype(float).mean(axis=(0, 2))[step : step + 30].min() > first[30:].max()
    assert abs(views.mean() - SensorSpec().target) < 1.0


def test_an_image_that_is_not_equirectangular_is_refused(tmp_path):
    path = tmp_path / "square.hdr"
    assert cv2.imwrite(str(path), np.ones((64, 64, 3), np.float32))
    with pytest.raises(ValueError, match=r"square\.hdr: expected an equirect.*\(64, 64, 3\)"):
        _real(path)
    with pytest.raises(ValueError, match=r"missing\.hdr: not a readable HDR"):
        _real(tmp_path / "missing.hdr")
