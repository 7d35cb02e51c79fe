"""Simulated rotation: rotated views of a panorama by circular column shifts.

A panorama is periodic in its width, and column ``c`` looks at azimuth
``heading + 2*pi*c/W`` (counter-clockwise). Turning the rover by ``+2*pi*s/W`` therefore
shifts the content by ``-s`` columns, so every rotation that is a whole number of columns
can be simulated without moving the rover. View ``k`` of a panorama is::

    np.roll(panorama, -k * step, axis=1)[:, :window]

with relative orientation ``phi_k = 2*pi*k*step/W``, for ``k = 0 .. W // step - 1``. The set of
views is periodic only if ``step`` divides ``W``, which is therefore required.
"""

from __future__ import annotations

from typing import Any, Literal, SupportsFloat

import gymnasium as gym
import numpy as np
from numpy.lib.stride_tricks import as_strided
from numpy.typing import NDArray

__all__ = ["n_rotations", "rotation_angles", "rotated_views", "SimulatedRotation"]


def _check_step(width: int, step: int) -> None:
    if isinstance(step, bool) or not isinstance(step, int | np.integer):
        raise TypeError(f"step must be an int (columns), got {step!r}")
    if not 1 <= step <= width:
        raise ValueError(f"step must lie in [1, {width}] (the panorama width), got {step}")
    if width % step != 0:
        raise ValueError(
            f"the panorama width {width} is not a multiple of step {step}: the rotated views "
            f"would not be periodic; choose a step that divides {width}"
        )


def _check_window(width: int, window: int | None) -> int:
    if window is None:
        return width
    if isinstance(window, bool) or not isinstance(window, int | np.integer):
        raise TypeError(f"window must be an int (columns) or None, got {window!r}")
    if not 1 <= window <= width:
        raise ValueError(f"window must lie in [1, {width}] (the panorama width), got {window}")
    return int(window)


def n_rotations(width: int, step: int = 5) -> int:
    """Number ``K = width // step`` of rotated views of a panorama ``width`` columns wide.

    Raises:
        ValueError: if ``step`` is outside ``[1, width]`` or does not divide ``width``.
    """
    if isinstance(width, bool) or not isinstance(width, int | np.integer) or width < 1:
        raise ValueError(f"width must be a positive int (columns), got {width!r}")
    _check_step(int(width), step)
    return int(width) // int(step)


def rotation_angles(width: int, step: int = 5) -> NDArray[np.float64]:
    """Relative orientations ``phi_k = 2*pi*k*step/width`` (radians) of the K views, ``(K,)``."""
    k = np.arange(n_rotations(width, step), dtype=np.float64)
    return 2.0 * np.pi * k * step / width


def rotated_views(
    panorama: NDArray[Any], step: int = 5, window: int | None = None
) -> tuple[NDArray[Any], NDArray[np.float64]]:
    """All simulated rotations of one panorama.

    Args:
        panorama: ``(H, W, C)`` image (uint8 RGB for the env's panoramas), periodic in ``W``.
        step: shift between consecutive views, in columns; must divide ``W``.
        window: keep only the first ``window`` columns of each view (a field of view of
            ``360 * window / W`` degrees); ``None`` keeps the full width.

    Returns:
        ``views``: fresh C-contiguous ``(K, H, window or W, C)`` array of the panorama's dtype,
        ``views[k] == np.roll(panorama, -k * step, axis=1)[:, :window]``;
        ``phis``: ``(K,)`` float64, ``phis[k] = 2*pi*k*step/W`` radians; ``K = W // step``.

    Example:
        >>> pano = np.arange(10, dtype=np.uint8).reshape(1, 10, 1)
        >>> views, phis = rotated_views(pano, step=5, window=3)
        >>> views[:, 0, :, 0].tolist(), np.degrees(phis).tolist()
        ([[0, 1, 2], [5, 6, 7]], [0.0, 180.0])
    """
    panorama = np.asarray(panorama)
    if panorama.ndim != 3:
        raise ValueError(f"panorama must have shape (H, W, C), got shape {panorama.shape}")
    height, width, channels = panorama.shape
    _check_step(width, step)
    window = _check_window(width, window)
    n_views = width // step
    # Append the first window-1 columns so that every view is a plain (non-wrapping) slice of
    # the extended panorama; the K views are then one strided view copied once.
    extended = np.ascontiguousarray(np.concatenate([panorama, panorama[:, : window - 1]], axis=1))
    s_row, s_col, s_chan = extended.strides
    strided = as_strided(
        extended,
        shape=(n_views, height, window, channels),
        strides=(step * s_col, s_row, s_col, s_chan),
        writeable=False,
    )
    return np.ascontiguousarray(strided), rotation_angles(width, step)


class SimulatedRotation(gym.ObservationWrapper, gym.utils.RecordConstructorArgs):
    """Replace each panorama by one simulated rotation of it.

    At every ``reset`` and ``step`` the wrapper picks a view index ``k`` and returns
    ``np.roll(panorama, -k * step, axis=1)[:, :window]``, i.e. what the camera would see had the
    rover been turned by ``phi = 2*pi*k*step/W`` more (counter-clockwise). The pose in ``info``
    stays the rover's true pose; ``info["phi"]`` (radians) and ``info["phi_index"]`` (``k``)
    report the simulated extra rotation.

    Args:
        env: an env whose observation space is a panorama, ``Box(0, 255, (H, W, 3), uint8)``.
        step: shift between rotations, in columns; must divide ``W``.
        window: crop each view to its first ``window`` columns; ``None`` keeps the full width.
        mode: ``"random"``: ``k`` drawn uniformly from ``0 .. W // step - 1`` with
            ``self.np_random`` (the wrapped env's generator, seeded by ``reset(seed=...)``) at
            every reset and step; ``"sequential"``: ``k = 0`` at reset, then ``k + 1`` (modulo
            ``K``) at every step.

    Example:
        >>> import gymnasium as gym
        >>> import sfa_gym
        >>> from sfa_gym.rotation import SimulatedRotation
        >>> env = SimulatedRotation(gym.make("sfa_gym/OmniRover-v0"), window=175, mode="sequential")
        >>> env.observation_space.shape
        (40, 175, 3)
        >>> obs, info = env.reset(seed=0)
        >>> info["phi_index"], info["phi"]
        (0, 0.0)
        >>> obs, *_, info = env.step(env.action_space.sample())
        >>> info["phi_index"], round(float(np.degrees(info["phi"])), 6)
        (1, 5.142857)
        >>> env.close()
    """

    def __init__(
        self,
        env: gym.Env,
        step: int = 5,
        window: int | None = None,
        mode: Literal["random", "sequential"] = "random",
    ) -> None:
        space = env.observation_space
        if (
            not isinstance(space, gym.spaces.Box)
            or len(space.shape) != 3
            or space.shape[2] != 3
            or space.dtype != np.uint8
        ):
            raise ValueError(
                "SimulatedRotation needs a panorama observation space Box(0, 255, (H, W, 3), "
                f"uint8), got {space}"
            )
        if mode not in ("random", "sequential"):
            raise ValueError(
                f"SimulatedRotation mode must be 'random' or 'sequential', got {mode!r}"
            )
        height, width, _ = space.shape
        try:
            n_views = n_rotations(width, step)
            window = _check_window(width, window)
        except (TypeError, ValueError) as error:
            raise type(error)(f"SimulatedRotation: {error}") from None
        gym.utils.RecordConstructorArgs.__init__(self, step=step, window=window, mode=mode)
        gym.ObservationWrapper.__init__(self, env)
        self.n_views = n_views
        self.rotation_step = int(step)
        self.window = window
        self.mode = mode
        self.phis = rotation_angles(width, step)
        self.observation_space = gym.spaces.Box(0, 255, (height, window, 3), np.uint8)
        self._index = 0

    def _columns(self, width: int) -> NDArray[np.intp]:
        return (self._index * self.rotation_step + np.arange(self.window)) % width

    def observation(self, observation: NDArray[np.uint8]) -> NDArray[np.uint8]:
        """View ``self._index`` of ``observation`` ``(H, W, 3)``: ``(H, window, 3)`` uint8."""
        return np.take(observation, self._columns(observation.shape[1]), axis=1)

    def _with_phi(self, info: dict[str, Any]) -> dict[str, Any]:
        return {**info, "phi": float(self.phis[self._index]), "phi_index": int(self._index)}

    def _draw(self) -> int:
        return int(self.np_random.integers(self.n_views))

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[NDArray[np.uint8], dict[str, Any]]:
        obs, info = self.env.reset(seed=seed, options=options)
        self._index = self._draw() if self.mode == "random" else 0
        return self.observation(obs), self._with_phi(info)

    def step(
        self, action: Any
    ) -> tuple[NDArray[np.uint8], SupportsFloat, bool, bool, dict[str, Any]]:
        obs, reward, terminated, truncated, info = self.env.step(action)
        if self.mode == "random":
            self._index = self._draw()
        else:
            self._index = (self._index + 1) % self.n_views
        return self.observation(obs), reward, terminated, truncated, self._with_phi(info)
