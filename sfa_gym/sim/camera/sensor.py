"""The camera's own effects on its pixels: motion blur, vignetting, auto-exposure (gain), auto
white balance and noise.

A real camera does not see the scene's radiance: it scales it by a gain that its auto-exposure
drives towards a target brightness, with a lag, and adds noise. Outdoors this matters: when a
cloud passes, the image first darkens and then the exposure brings it back.

* Auto-exposure: the gain ``g`` moves towards ``target / mean brightness`` with the time
  constant ``tau_s`` (per frame by the fraction ``1 - exp(-dt / tau_s)``, in log gain), clipped
  to ``gain_range``. The meter averages the pixels that are not black in every channel (a
  mirror camera's image is black outside the mirror's disc). :meth:`Sensor.reset` sets it to
  the steady value of the first frame, so an episode starts well exposed.
* Motion blur (off by default): a frame integrates the scene over its exposure, and a rover
  turning at ``w`` rad/s sweeps its camera ``w * exposure`` radians of azimuth meanwhile. A
  panorama's columns are azimuths, so the frame is the last instant's panorama averaged over
  its shifts from 0 to ``w * exposure * W / (2 pi)`` columns (:func:`azimuth_blur`: a box
  along the row, exact for a turn at a constant rate and the panorama linear between columns).
  The exposure is ``exposure_s`` at unit gain and grows with the auto-exposure's gain (a camera
  exposes longer before it amplifies), at most the frame interval. Driving straight blurs too
  (the scene's parallax), far less at the rover's speeds; it is not modelled.
* Vignetting (off by default): the lens passes less light away from its axis, by the ``cos^4``
  law of the angle off the axis; the camera gives the relative illumination of each pixel
  (:func:`sfa_gym.sim.camera.mirror.vignetting_gain`: ``1 - vignetting`` at the mirror's rim).
  It acts before the meter, as on a real sensor, and the lens's output is whole grey levels.
* Auto white balance (off by default): a gain per colour channel that moves, with the
  exposure's lag, towards the grey world's value (the channels' mean over their common mean,
  metered on the same pixels), clipped to ``white_balance_range``: under a blue sky or an
  evening sun the colours drift and come back, as a consumer camera's do.
* Noise: Gaussian read noise of ``read_noise`` grey levels plus shot noise whose variance grows
  with the signal (``shot_noise**2 * value``), drawn from the generator the caller passes
  (the env derives it from its seed: same seed, same noise).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = ["Sensor", "SensorSpec", "azimuth_blur"]


@dataclass(frozen=True)
class SensorSpec:
    """Auto-exposure and noise of a camera; grey levels are 0..255.

    Attributes:
        auto_exposure: drive the gain towards ``target``.
        target: mean brightness (grey levels) the auto-exposure aims at.
        tau_s: time constant of the auto-exposure, s.
        gain_range: ``[min, max]`` gain.
        noise: add pixel noise.
        read_noise: standard deviation of the signal-independent noise, grey levels.
        shot_noise: shot noise: standard deviation ``shot_noise * sqrt(value)``.
        white_balance: drive a gain per colour channel towards the grey world's.
        white_balance_range: ``[min, max]`` gain of a channel.
        vignetting: share of the light lost at the edge of the image (the mirror's rim),
            ``0 <= vignetting < 1``; 0: none.
        exposure_s: exposure time at unit gain, s; the auto-exposure scales it by its gain,
            capped at the frame interval. 0: instantaneous frames (no motion blur). Daylight
            consumer cameras expose about 1/1000 s and less; indoors 1/30-1/60 s.
    """

    auto_exposure: bool = True
    target: float = 100.0
    tau_s: float = 1.5
    gain_range: tuple[float, float] = (0.3, 4.0)
    noise: bool = True
    read_noise: float = 1.5
    shot_noise: float = 0.25
    white_balance: bool = False
    white_balance_range: tuple[float, float] = (0.5, 2.0)
    vignetting: float = 0.0
    exposure_s: float = 0.0

    def __post_init__(self) -> None:
        for name in ("auto_exposure", "noise", "white_balance"):
            value = getattr(self, name)
            if not isinstance(value, bool):
                raise ValueError(f"{name} must be True or False, got {value!r}")
        if not 0.0 < self.target < 255.0:
            raise ValueError(f"target must lie in (0, 255) grey levels, got {self.target!r}")
        if not self.tau_s > 0:
            raise ValueError(f"tau_s must be > 0 seconds, got {self.tau_s!r}")
        lo, hi = self.gain_range
        if not 0.0 < lo <= 1.0 <= hi:
            raise ValueError(
                f"gain_range must be [min, max] with 0 < min <= 1 <= max, got {[lo, hi]}"
            )
        for name in ("read_noise", "shot_noise"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be a number >= 0, got {value!r}")
        lo, hi = self.white_balance_range
        if not 0.0 < lo <= 1.0 <= hi:
            raise ValueError(
                f"white_balance_range must be [min, max] with 0 < min <= 1 <= max, got {[lo, hi]}"
            )
        v = self.vignetting
        if isinstance(v, bool) or not (isinstance(v, int | float) and 0.0 <= v < 1.0):
            raise ValueError(f"vignetting must be a number in [0, 1), got {v!r}")
        e = self.exposure_s
        if isinstance(e, bool) or not (isinstance(e, int | float) and 0.0 <= e < math.inf):
            raise ValueError(f"exposure_s must be a finite number of seconds >= 0, got {e!r}")

    @property
    def active(self) -> bool:
        """Whether the sensor changes any pixel."""
        noisy = self.noise and (self.read_noise > 0 or self.shot_noise > 0)
        effects = self.auto_exposure or self.white_balance or self.vignetting > 0
        return effects or noisy or self.exposure_s > 0


class Sensor:
    """The state of one camera's sensor (its gains) between frames.

    Args:
        spec: the sensor's effects.
        falloff: with ``spec.vignetting``: the relative illumination of each pixel ``(H, W)``,
            from the camera (:func:`sfa_gym.sim.camera.mirror.vignetting_gain`).
    """

    def __init__(self, spec: SensorSpec, falloff: NDArray[np.float32] | None = None) -> None:
        if not isinstance(spec, SensorSpec):
            raise TypeError(f"spec must be a SensorSpec, got {type(spec).__name__}")
        if (spec.vignetting > 0) != (falloff is not None):
            raise ValueError(
                f"vignetting {spec.vignetting} needs the camera's falloff map, and only then one"
            )
        self.spec = spec
        self.falloff = None if falloff is None else np.asarray(falloff, np.float32)[..., None]
        self.gain = 1.0
        self.balance = np.ones(3)

    def _steady_gain(self, image: NDArray[np.uint8]) -> float:
        lo, hi = self.spec.gain_range
        # the meter ignores pixels black in every channel (outside a mirror's disc); they add
        # nothing to the sum, so the mean over the lit ones is the sum over the lit count (an
        # exact integer sum: the same number as the mean over a copy of the lit pixels)
        if image.ndim == 3:
            lit = image[..., 0].copy()
            for channel in range(1, image.shape[-1]):  # an OR per channel: 10x a reduce
                lit |= image[..., channel]
            count = np.count_nonzero(lit) * image.shape[-1]
        else:
            count = np.count_nonzero(image)
        mean = max(int(image.sum(dtype=np.uint64)) / count if count else 0.0, 1.0)
        return min(hi, max(lo, self.spec.target / mean))

    def _steady_balance(self, image: NDArray[np.uint8]) -> NDArray[np.float64]:
        """The grey world's gain per channel: the channels' common mean over each one's."""
        if image.ndim < 3 or image.shape[-1] != 3:
            raise ValueError(f"white balance needs RGB images (..., 3), got shape {image.shape}")
        sums = np.array([int(image[..., c].sum(dtype=np.uint64)) for c in range(3)], float)
        sums = np.maximum(sums, 1.0)  # exact integer sums, as the exposure's
        lo, hi = self.spec.white_balance_range
        return np.clip(sums.mean() / sums, lo, hi)

    def exposure(self, dt: float) -> float:
        """The exposure of a frame ``dt`` seconds after the previous one, s: ``exposure_s``
        times the gain the auto-exposure has set (1 without), at most ``dt``."""
        gain = self.gain if self.spec.auto_exposure else 1.0
        return min(self.spec.exposure_s * gain, dt)

    def _optics(
        self, image: NDArray[np.uint8], dt: float = 0.0, yaw_rate: float = 0.0
    ) -> NDArray[np.uint8]:
        """The image the lens delivers to the sensor: smeared by the turn during the exposure
        (the scene moves across the sensor, the lens's falloff does not), vignetted, in whole
        grey levels."""
        if self.spec.exposure_s > 0 and yaw_rate != 0 and dt > 0:
            columns = yaw_rate * self.exposure(dt) * image.shape[1] / (2 * math.pi)
            image = azimuth_blur(image, columns)
        if self.falloff is None:
            return image
        lens = image * self.falloff
        np.rint(lens, out=lens)
        return lens.astype(np.uint8)

    def reset(self, image: NDArray[np.uint8]) -> None:
        """Start from the gains at which ``image`` (the raw first frame) is well exposed."""
        image = self._optics(image)
        self.gain = self._steady_gain(image) if self.spec.auto_exposure else 1.0
        self.balance = self._steady_balance(image) if self.spec.white_balance else np.ones(3)

    def process(
        self,
        image: NDArray[np.uint8],
        dt: float,
        rng: np.random.Generator,
        yaw_rate: float = 0.0,
    ) -> NDArray[np.uint8]:
        """The frame the camera delivers for the raw frame ``image`` (uint8, any shape; with
        motion blur a panorama ``(H, W, ...)`` whose columns are azimuths), ``dt`` seconds after
        the previous one, the camera turning at ``yaw_rate`` rad/s (counter-clockwise > 0).
        The exposure time follows the gain the previous frames set; then the gains are updated,
        and applied."""
        spec = self.spec
        image = self._optics(image, dt, yaw_rate)
        # first-order lag in log gain: equal steps up and down in stops
        alpha = 1.0 - math.exp(-dt / spec.tau_s) if dt > 0 else 0.0
        if spec.auto_exposure and dt > 0:
            self.gain = math.exp(
                (1 - alpha) * math.log(self.gain) + alpha * math.log(self._steady_gain(image))
            )
        if spec.white_balance and dt > 0:
            steady = np.log(self._steady_balance(image))
            self.balance = np.exp((1 - alpha) * np.log(self.balance) + alpha * steady)
        if not spec.active:
            return image
        signal = image.astype(np.float32)
        if spec.white_balance:
            signal *= (self.gain * self.balance).astype(np.float32)
        elif spec.auto_exposure:
            signal *= np.float32(self.gain)
        if spec.noise:  # in place, in float32: the same numbers with fewer temporaries
            noise = rng.standard_normal(signal.shape, dtype=np.float32)
            std = np.multiply(signal, np.float32(spec.shot_noise**2))
            std += np.float32(spec.read_noise**2)
            np.sqrt(std, out=std)
            noise *= std
            signal += noise
        np.rint(signal, out=signal)
        np.clip(signal, 0, 255, out=signal)
        return signal.astype(np.uint8)


def azimuth_blur(image: NDArray[np.uint8], columns: float) -> NDArray[np.uint8]:
    """A panorama ``(H, W, ...)`` (column ``c`` at azimuth ``2 pi c / W``, counter-clockwise)
    as a camera turning counter-clockwise by ``columns`` columns during its exposure records it:
    the mean of the panorama shifted by every amount from 0 to ``columns`` (negative: the other
    way), the panorama taken as linear between its columns; whole grey levels. Beyond a full
    turn the blur is that of a full turn.

    A camera turning counter-clockwise sees the scene move to lower columns, so the frame's
    content at column ``c`` was at ``c + s`` columns ``s`` before the exposure ended: the
    average over shifts towards higher columns.
    """
    width = image.shape[1]
    length = min(abs(float(columns)), float(width))
    if length < 1e-6:
        return image
    # weight of the shift by j columns: the box [0, length] against the linear interpolation's
    # triangle around j, divided by the box's length (the weights sum to 1)
    shifts = np.arange(int(math.ceil(length)) + 2)
    weights = (_ramp(length - shifts) - _ramp(-shifts.astype(float))) / length
    sign = 1 if columns > 0 else -1
    out = np.zeros(image.shape, np.float32)
    for shift, weight in zip(shifts, weights, strict=True):
        if weight > 0:
            out += np.float32(weight) * np.roll(image, sign * int(shift), axis=1)
    np.rint(out, out=out)
    np.clip(out, 0, 255, out=out)
    return out.astype(np.uint8)


def _ramp(x: NDArray[np.float64]) -> NDArray[np.float64]:
    """The integral of the unit triangle ``max(0, 1 - |u|)`` from -inf to ``x``."""
    x = np.clip(x, -1.0, 1.0)
    return np.where(x < 0, (x + 1) ** 2 / 2, 1 - (1 - x) ** 2 / 2)
