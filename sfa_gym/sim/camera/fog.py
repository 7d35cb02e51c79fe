"""Fog and haze on the camera's views, by Koschmieder's law.

Light from a surface at distance ``d`` along a viewing ray reaches the camera attenuated by the
transmission ``t = exp(-beta * d)``, and the fog scatters daylight into the ray on the way (the
*airlight* ``A``): the camera sees ``L = L0 * t + A * (1 - t)`` (Koschmieder 1924; Middleton,
*Vision through the atmosphere*, 1952). The extinction coefficient follows from the
meteorological visibility ``V``, the distance at which a black object's contrast against the
horizon falls to 2 %: ``beta = -ln(0.02) / V = 3.912 / V``. The sky (no surface within the far
plane) is then airlight alone, as in real fog.

The distance of every pixel comes from the view's depth buffer (read beside the colours), the
pinhole geometry giving the ray's length from the eye depth. The airlight is the light a white,
matte, upward-facing surface reflects under the model's lights (the ambient light plus each
directional light's diffuse light times the cosine of its elevation): the fog is lit by the
same daylight as the scene, and brightens and darkens with it. Fog is applied to the rendered
views before they are resampled into the panorama, so the mirror camera gets it too.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:  # imported where used: MUJOCO_GL must be set before mujoco is imported
    import mujoco

__all__ = [
    "CONTRAST_THRESHOLD",
    "airlight",
    "apply_fog",
    "check_visibility",
    "eye_depths",
    "ray_lengths",
]

CONTRAST_THRESHOLD = 0.02
"""The contrast at the meteorological visibility (WMO: 2 % for the visual range)."""


def check_visibility(visibility_m: float | None) -> float | None:
    """``visibility_m`` (metres, > 0 and finite) or None (clear air).

    Raises:
        ValueError: another value; the message names it.
    """
    if visibility_m is None:
        return None
    if (
        isinstance(visibility_m, bool)
        or not isinstance(visibility_m, int | float)
        or not math.isfinite(visibility_m)
        or visibility_m <= 0
    ):
        raise ValueError(
            f"visibility_m must be a distance > 0 m (fog: below 1000) or None, got {visibility_m!r}"
        )
    return float(visibility_m)


def extinction(visibility_m: float) -> float:
    """The extinction coefficient ``beta`` (1/m) of the meteorological visibility."""
    return -math.log(CONTRAST_THRESHOLD) / visibility_m


def ray_lengths(
    width: int, height: int, rects: list[tuple[int, int, int, int]], focal: float
) -> NDArray[np.float32]:
    """Length of each pixel's viewing ray per unit of eye depth, ``(height, width)`` in the
    read-back buffer's layout (row 0 at the bottom, as OpenGL reads it): ``sqrt(1 + u^2 +
    v^2)`` for the pixel centre's offsets ``u, v`` from its view's centre in focal lengths.

    Args:
        width: the buffer's columns.
        height: the buffer's rows.
        rects: each view's ``(left, bottom, view_w, view_h)`` in the buffer.
        focal: the views' focal length in pixels.
    """
    out = np.ones((height, width), dtype=np.float32)
    for left, bottom, view_w, view_h in rects:
        u = (np.arange(view_w) + 0.5 - view_w / 2.0) / focal
        v = (np.arange(view_h) + 0.5 - view_h / 2.0) / focal
        out[bottom : bottom + view_h, left : left + view_w] = np.sqrt(
            1.0 + u[None, :] ** 2 + v[:, None] ** 2
        )
    return out


def airlight(model: mujoco.MjModel, data: mujoco.MjData) -> NDArray[np.float64]:
    """The fog's own radiance, RGB in 0..255 (module docstring): the light a white, matte,
    upward-facing surface reflects, clipped to white."""
    import mujoco

    light = np.array(model.vis.headlight.ambient, dtype=np.float64)
    for i in range(model.nlight):
        if not model.light_active[i]:
            continue
        light += model.light_ambient[i]
        if model.light_type[i] == mujoco.mjtLightType.mjLIGHT_DIRECTIONAL:
            light += model.light_diffuse[i] * max(0.0, -float(data.light_xdir[i][2]))
    return 255.0 * np.minimum(light, 1.0)


def eye_depths(depth: NDArray[np.float32], znear: float, zfar: float) -> NDArray[np.float32]:
    """The eye depth (m) of each value of a depth buffer (window depth in ``[0, 1]``) of a
    perspective projection from ``znear`` to ``zfar`` (m)."""
    return (znear * zfar) / (zfar - depth * (zfar - znear))


def apply_fog(
    buffer: NDArray[np.uint8],
    depth: NDArray[np.float32],
    lengths: NDArray[np.float32],
    znear: float,
    zfar: float,
    visibility_m: float,
    air: NDArray[np.float64],
) -> None:
    """Blend ``buffer (H, W, 3)`` uint8 in place towards the airlight ``air`` by each pixel's
    transmission (module docstring).

    Args:
        buffer: the views' colours as read back.
        depth: the depth buffer ``(H, W)``, window depth in ``[0, 1]`` of a perspective
            projection from ``znear`` to ``zfar`` (metres).
        lengths: :func:`ray_lengths` of the buffer.
        znear: the near plane's distance, m.
        zfar: the far plane's distance, m.
        visibility_m: the meteorological visibility.
        air: the airlight, RGB 0..255.
    """
    eye_depth = eye_depths(depth, znear, zfar)
    transmission = np.exp(-extinction(visibility_m) * eye_depth * lengths)[..., None]
    blended = buffer * transmission + air.astype(np.float32) * (1.0 - transmission)
    np.rint(blended, out=blended)
    buffer[:] = blended.astype(np.uint8)
