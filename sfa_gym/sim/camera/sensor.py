"""The camera's own effects on its pixels: auto-exposure (gain) and noise.

A real camera does not see the scene's radiance: it scales it by a gain that its auto-exposure
drives towards a target brightness, with a lag, and adds noise. Outdoors this matters: when a
cloud passes, the image first darkens and then the exposure brings it back.

* Auto-exposure: the gain ``g`` moves towards ``target / mean brightness`` with the time
  constant ``tau_s`` (per frame by the fraction ``1 - exp(-dt / tau_s)``, in log gain), clipped
  to ``gain_range``. The meter averages the pixels that are not black in every channel (a
  mirror camera's image is black outside the mirror's disc). :meth:`Sensor.reset` sets it to
  the steady value of the first frame, so an episode starts well exposed.
* Noise: Gaussian read noise of ``read_noise`` grey levels plus shot noise whose variance grows
  with the signal (``shot_noise**2 * value``), drawn from the generator the caller passes
  (the env derives it from its seed: same seed, same noise).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

__all__ = ["Sensor", "SensorSpec", "resolve_sensor"]


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
    """

    auto_exposure: bool = True
    target: float = 100.0
    tau_s: float = 1.5
    gain_range: tuple[float, float] = (0.3, 4.0)
    noise: bool = True
    read_noise: float = 1.5
    shot_noise: float = 0.25

    def __post_init__(self) -> None:
        for name in ("auto_exposure", "noise"):
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

    @property
    def active(self) -> bool:
        """Whether the sensor changes any pixel."""
        return self.auto_exposure or (self.noise and (self.read_noise > 0 or self.shot_noise > 0))


class Sensor:
    """The state of one camera's sensor (its gain) between frames."""

    def __init__(self, spec: SensorSpec) -> None:
        if not isinstance(spec, SensorSpec):
            raise TypeError(f"spec must be a SensorSpec, got {type(spec).__name__}")
        self.spec = spec
        self.gain = 1.0

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

    def reset(self, image: NDArray[np.uint8]) -> None:
        """Start from the gain at which ``image`` (the raw first frame) is well exposed."""
        self.gain = self._steady_gain(image) if self.spec.auto_exposure else 1.0

    def process(
        self, image: NDArray[np.uint8], dt: float, rng: np.random.Generator
    ) -> NDArray[np.uint8]:
        """The frame the camera delivers for the raw frame ``image`` (uint8, any shape),
        ``dt`` seconds after the previous one; updates the gain first."""
        spec = self.spec
        if spec.auto_exposure and dt > 0:
            # first-order lag in log gain: equal steps up and down in stops
            alpha = 1.0 - math.exp(-dt / spec.tau_s)
            self.gain = math.exp(
                (1 - alpha) * math.log(self.gain) + alpha * math.log(self._steady_gain(image))
            )
        if not spec.active:
            return image
        signal = image.astype(np.float32)
        if spec.auto_exposure:
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


def resolve_sensor(
    sensor: bool | SensorSpec | None, auto_exposure: bool | None, noise: bool | None
) -> SensorSpec | None:
    """The sensor an env runs: none (None or False), the defaults (True) or the given spec,
    with ``auto_exposure`` and ``noise`` overriding its fields when given (True/False).

    Raises:
        ValueError: a switch that is not a bool or None, or one turned on without a sensor.
    """
    if sensor is None or sensor is False:
        spec = None
    elif sensor is True:
        spec = SensorSpec()
    elif isinstance(sensor, SensorSpec):
        spec = sensor
    else:
        raise TypeError(f"sensor must be None, a bool or a SensorSpec, got {sensor!r}")
    given = {}
    for field, name, value in (
        ("auto_exposure", "auto_exposure", auto_exposure),
        ("noise", "sensor_noise", noise),
    ):
        if value is not None and not isinstance(value, bool):
            raise ValueError(f"{name} must be True, False or None, got {value!r}")
        if value is not None:
            given[field] = value
    if spec is None:
        if any(given.values()):
            raise ValueError(
                f"{sorted(k for k, v in given.items() if v)} need a sensor; pass sensor=True"
            )
        return None
    return replace(spec, **given) if given else spec
