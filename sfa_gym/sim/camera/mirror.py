"""Catadioptric (mirror) camera: the unified central camera model, its circular image and the
polar unwarp to a panorama.

A camera under a convex mirror of revolution, looking up along the mast, sees the surroundings
in a disc. The unified model (Geyer and Daniilidis; Mei and Rives) describes every central
catadioptric camera alike: a direction is put on the unit sphere, the sphere is viewed from a
point shifted by ``xi`` along the mirror's axis, and the result is projected with a pinhole of
focal length ``gamma`` (pixels) around the image centre ``(cx, cy)``. ``xi = 0`` is a pinhole,
``xi = 1`` a parabolic mirror; a dome or egg-shaped chrome mirror, like the paper's egg warmer,
is roughly 0.8 .. 1.0.

Conventions (:func:`project`, :func:`lift`, :class:`MirrorCamera`):

* the camera looks up at the mirror, so the image centre shows the lowest elevation (the camera
  and mast themselves, outside the mirror's useful range: black) and the disc's rim the highest;
  the radius grows monotonically with the elevation, ``r(e) = gamma cos(e) / (xi - sin(e))``;
* the rover's heading points up in the image (smaller row index ``v``), and the azimuth,
  counter-clockwise from the heading seen from above, grows *clockwise* in the image: the
  image is seen from below, so the rover's left lies on the image's right;
* pixel centres are at integer ``(u, v)``; ``u`` is the column, ``v`` the row.

:class:`MirrorCamera` renders a high-resolution cylindrical panorama with an
:class:`~sfa_gym.sim.camera.renderer.OmniCamera` of :meth:`MirrorSpec.view_spec`, resamples it
into the circular image with one precomputed ``cv2.remap``, and unwarps that with a second one
(:func:`unwarp`) around a centre that may be deliberately off the true one: the paper's mirror
was uncalibrated, and an off-centre unwarp makes the panorama's rows wobble with the azimuth,
so that turning the rover no longer shifts the panorama exactly.

The unwarped panorama follows the project's convention: column ``c`` looks at azimuth
``heading + 2*pi*c/W`` (counter-clockwise), row 0 is the top (the highest elevation of the
unwarp range). Its rows are spaced evenly in image radius ("radius", what an unwarp of an
uncalibrated mirror does) or in elevation ("elevation", through the model).

Cost (llvmpipe on 2 CPU cores): rendering the view panorama dominates; the two remaps and the
disc's mask take about 1 ms at 480 pixels. The view panorama is symmetric about the horizon, so
the mirror's elevation range sets its height: the preset's -35 .. +25 degrees at half the rim's
density (``view_scale`` 0.5) render in about 1.3 times a cylindrical 600 x 60 panorama (8.6 vs
6.8 ms; an env step about 1.2 times), -45 .. +25 in 1.6 times, ``view_scale`` 1 in 3.8 times.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal, get_args

import cv2
import numpy as np
from numpy.typing import ArrayLike, NDArray

from sfa_gym._checks import check_finite, check_int_in
from sfa_gym.sim.camera.projection import PanoramaSpec

if TYPE_CHECKING:
    import mujoco

__all__ = [
    "MirrorCamera",
    "MirrorSpec",
    "UnwarpRows",
    "lift",
    "project",
    "unwarp",
    "vignetting_gain",
]

UnwarpRows = Literal["radius", "elevation"]
"""How the unwarped panorama's rows are spaced: evenly in image radius or in elevation."""

# The cylindrical view panorama covers this much (degrees) beyond the mirror's elevation range,
# so that bilinear samples of the disc's inner and outer rings stay inside it.
_VIEW_MARGIN_DEG = 1.0
_MAX_ELEVATION_DEG = 75.0 - _VIEW_MARGIN_DEG
_MAX_IMAGE_SIZE = 4096
_MAX_PANORAMA_SIDE = 1 << 14


def _pair(name: str, value: object) -> tuple[float, float]:
    if not isinstance(value, tuple | list) or len(value) != 2:
        raise ValueError(f"MirrorSpec.{name} must be a pair of numbers, got {value!r}")
    low, high = (check_finite(f"MirrorSpec.{name}", v) for v in value)
    return low, high


@dataclass(frozen=True)
class MirrorSpec:
    """Geometry of a catadioptric camera (unified central model) and of its unwarped panorama.

    Attributes:
        xi: mirror parameter of the unified model, in [0, 1] (0 pinhole, 1 parabolic).
        gamma: generalised focal length, pixels, > 0.
        image_size: side ``S`` of the square circular image, pixels, in [16, 4096].
        centre: image centre ``(cx, cy)`` in pixels (pixel centres at integers), where the
            mirror's axis meets the image; None (default) for the image's middle
            ``((S - 1) / 2, (S - 1) / 2)``.
        elevation_range_deg: ``(low, high)`` elevations (degrees, horizon 0) the mirror shows,
            from the inner ring to the rim; ``-74 <= low < high < min(asin(xi), 74)`` (the
            view panorama is symmetric about the horizon and reaches 75 degrees), and the rim
            must fit in the image.
        panorama_width: columns ``W`` of the unwarped panorama (over 360 degrees).
        panorama_height: rows ``H`` of the unwarped panorama.
        unwarp_elevation_deg: ``(low, high)`` elevations (degrees) of the panorama's bottom
            and top edges, within ``elevation_range_deg``; the unwarp's radius range is
            ``r(low) .. r(high)`` of the model.
        unwarp_rows: "radius" (rows evenly spaced in image radius, as an unwarp of an
            uncalibrated mirror does) or "elevation" (evenly in elevation, through the model).
        unwarp_centre_offset: ``(dx, dy)`` pixels: the unwarp is done around ``(cx + dx,
            cy + dy)`` instead of the true centre, modelling an uncalibrated mirror; its length
            is limited so that the unwarp never samples outside the mirror's disc.
        supersample: the unwarp samples ``supersample`` times denser in both directions and
            box-filters down (anti-aliasing where the disc is denser than the panorama), in
            [1, 4].
        n_views: pinhole views of the cylindrical view panorama, in [3, 64]; more views render
            fewer pixels (less oversampling at their sides) but cost more draw calls.
        view_scale: pixel density of the view panorama relative to the circular image's
            highest density (at the rim), in [0.25, 4]. The default 0.5 resolves the circular
            image fully up to about the horizon and half as finely at the rim, which the
            unwarped 600-column panorama does not resolve anyway (its pixels differ from
            ``view_scale=1`` by about 1.3 grey levels on average), at about a third of the
            rendering cost.
    """

    xi: float = 0.9
    gamma: float = 118.5
    image_size: int = 480
    centre: tuple[float, float] | None = None
    elevation_range_deg: tuple[float, float] = (-35.0, 25.0)
    panorama_width: int = 600
    panorama_height: int = 60
    unwarp_elevation_deg: tuple[float, float] = (-30.0, 20.0)
    unwarp_rows: UnwarpRows = "radius"
    unwarp_centre_offset: tuple[float, float] = (0.0, 0.0)
    supersample: int = 2
    n_views: int = 8
    view_scale: float = 0.5

    def __post_init__(self) -> None:
        xi = check_finite("MirrorSpec.xi", self.xi)
        if not 0.0 <= xi <= 1.0:
            raise ValueError(f"MirrorSpec.xi must be in [0, 1], got {self.xi!r}")
        gamma = check_finite("MirrorSpec.gamma", self.gamma)
        if gamma <= 0.0:
            raise ValueError(f"MirrorSpec.gamma must be > 0 pixels, got {self.gamma!r}")
        size = check_int_in("MirrorSpec.image_size", self.image_size, 16, _MAX_IMAGE_SIZE)
        centre = ((size - 1) / 2.0,) * 2 if self.centre is None else _pair("centre", self.centre)
        if not all(0.0 <= c <= size - 1 for c in centre):
            raise ValueError(
                f"MirrorSpec.centre must lie in the image, [0, {size - 1}] per axis, "
                f"got {self.centre!r}"
            )
        low, high = _pair("elevation_range_deg", self.elevation_range_deg)
        # the mirror shows nothing at asin(xi) and above; the view panorama is symmetric about
        # the horizon, and a PanoramaSpec reaches at most +-75 degrees
        limit = min(math.degrees(math.asin(xi)), _MAX_ELEVATION_DEG)
        if not -_MAX_ELEVATION_DEG <= low < high < limit:
            raise ValueError(
                f"MirrorSpec.elevation_range_deg must be (low, high) with "
                f"{-_MAX_ELEVATION_DEG:g} <= low < high < {limit:.4g} degrees (asin(xi) and the "
                f"view panorama's reach), got {self.elevation_range_deg!r}"
            )
        check_int_in("MirrorSpec.panorama_width", self.panorama_width, 1, _MAX_PANORAMA_SIDE)
        check_int_in("MirrorSpec.panorama_height", self.panorama_height, 1, _MAX_PANORAMA_SIDE)
        u_low, u_high = _pair("unwarp_elevation_deg", self.unwarp_elevation_deg)
        if not low <= u_low < u_high <= high:
            raise ValueError(
                f"MirrorSpec.unwarp_elevation_deg must be (low, high) with {low:g} <= low < "
                f"high <= {high:g} (elevation_range_deg), got {self.unwarp_elevation_deg!r}"
            )
        if self.unwarp_rows not in get_args(UnwarpRows):
            raise ValueError(
                f"MirrorSpec.unwarp_rows must be one of {list(get_args(UnwarpRows))}, "
                f"got {self.unwarp_rows!r}"
            )
        check_int_in("MirrorSpec.supersample", self.supersample, 1, 4)
        check_int_in("MirrorSpec.n_views", self.n_views, 3, 64)
        scale = check_finite("MirrorSpec.view_scale", self.view_scale)
        if not 0.25 <= scale <= 4.0:
            raise ValueError(f"MirrorSpec.view_scale must be in [0.25, 4], got {self.view_scale!r}")
        radii = tuple(_radius(xi, gamma, math.radians(e)) for e in (low, high, u_low, u_high))
        room = min(centre[0], centre[1], size - 1 - centre[0], size - 1 - centre[1]) + 0.5
        if radii[1] > room:
            raise ValueError(
                f"MirrorSpec.gamma {self.gamma!r} puts the mirror's rim (elevation {high:g} deg) "
                f"{radii[1]:.1f} px from the centre, but the image edge is {room:.1f} px away; "
                "use a smaller gamma or a larger image_size"
            )
        dx, dy = _pair("unwarp_centre_offset", self.unwarp_centre_offset)
        margin = min(radii[2] - radii[0], radii[1] - radii[3])
        if math.hypot(dx, dy) > margin:
            raise ValueError(
                f"MirrorSpec.unwarp_centre_offset {self.unwarp_centre_offset!r} is "
                f"{math.hypot(dx, dy):.2f} px long; at most {margin:.2f} px keeps the unwarp "
                "inside the mirror's disc (or widen elevation_range_deg)"
            )
        # pairs as tuples of floats: the spec stays hashable (its remap tables are cached)
        for name, value in (
            ("elevation_range_deg", (low, high)),
            ("unwarp_elevation_deg", (u_low, u_high)),
            ("unwarp_centre_offset", (dx, dy)),
        ):
            object.__setattr__(self, name, value)
        if self.centre is not None:
            object.__setattr__(self, "centre", centre)

    @classmethod
    def paper_outdoor(cls) -> MirrorSpec:
        """A dome mirror like the paper's outdoor camera, unwarped to 600 x 60 pixels.

        ``xi`` 0.9, a 480-pixel circular image whose disc shows -35 .. +25 degrees (rings at
        66 and 225 px), unwarped over -30 .. +20 degrees (73 .. 200 px) with rows evenly
        spaced in radius, around a centre 2.5 px off the true one (the paper's mirror was not
        calibrated). Rendering costs about 1.3 times a cylindrical 600 x 60 panorama.
        """
        return cls(unwarp_centre_offset=(2.0, -1.5))

    @property
    def cx(self) -> float:
        """Image centre's column, pixels."""
        return (self.image_size - 1) / 2.0 if self.centre is None else self.centre[0]

    @property
    def cy(self) -> float:
        """Image centre's row, pixels."""
        return (self.image_size - 1) / 2.0 if self.centre is None else self.centre[1]

    def _radius_deg(self, elevation_deg: float) -> float:
        return float(_radius(self.xi, self.gamma, math.radians(elevation_deg)))

    @property
    def disc_radii(self) -> tuple[float, float]:
        """Inner and outer radius (pixels) of the mirror's annulus in the circular image."""
        return self._radius_deg(self.elevation_range_deg[0]), self._radius_deg(
            self.elevation_range_deg[1]
        )

    @property
    def unwarp_radii(self) -> tuple[float, float]:
        """Radii (pixels) of the unwarped panorama's bottom and top edges."""
        return self._radius_deg(self.unwarp_elevation_deg[0]), self._radius_deg(
            self.unwarp_elevation_deg[1]
        )

    @property
    def circular_shape(self) -> tuple[int, int, int]:
        """Shape of the circular image, ``(S, S, 3)``."""
        return self.image_size, self.image_size, 3

    @property
    def panorama_shape(self) -> tuple[int, int, int]:
        """Shape of the unwarped panorama, ``(H, W, 3)``."""
        return self.panorama_height, self.panorama_width, 3

    def view_spec(self) -> PanoramaSpec:
        """The cylindrical panorama rendered first and resampled into the circular image.

        Its field of view is symmetric about the horizon and covers the mirror's elevation
        range (plus a degree). Its columns match the circular image's density along the rim
        (``r`` pixels per radian of azimuth), its rows the largest radial density ``dr/de``
        (also at the rim), each times ``view_scale``; the views are rendered at the larger
        of the two. Build the rover's cameras with ``rover_mjcf(rover, mirror.view_spec())``.
        """
        low, high = self.elevation_range_deg
        vfov_deg = 2.0 * (max(abs(low), abs(high)) + _VIEW_MARGIN_DEG)
        elevations = np.radians(np.linspace(low, high, 256))
        radial = float(_radial_density(self.xi, self.gamma, elevations).max())
        return PanoramaSpec(
            width=math.ceil(2.0 * math.pi * self.view_scale * self.disc_radii[1]),
            height=math.ceil(math.radians(vfov_deg) * self.view_scale * radial),
            vfov_deg=vfov_deg,
            n_views=self.n_views,
            supersample=1,
        )


def _radius(xi: float, gamma: float, elevation: Any) -> Any:
    """Image radius (pixels) of a direction at ``elevation`` (radians): ``gamma cos(e) /
    (xi - sin(e))``."""
    return gamma * np.cos(elevation) / (xi - np.sin(elevation))


def _radial_density(xi: float, gamma: float, elevation: Any) -> Any:
    """``dr/de``, pixels per radian of elevation."""
    s = np.sin(elevation)
    return gamma * (1.0 - xi * s) / (xi - s) ** 2


def _check_spec(spec: object) -> MirrorSpec:
    if not isinstance(spec, MirrorSpec):
        raise TypeError(f"spec must be a MirrorSpec, got {type(spec).__name__}")
    return spec


def project(
    spec: MirrorSpec, azimuth: ArrayLike, elevation: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Pixel ``(u, v)`` (column, row) where the direction ``(azimuth, elevation)`` appears.

    Args:
        spec: the camera.
        azimuth: radians, counter-clockwise from the heading (seen from above); any shape.
        elevation: radians above the horizon, below ``asin(xi)``; broadcast with azimuth.
    Returns:
        ``(u, v)``, float64 arrays of the broadcast shape. Directions the mirror cannot show
        (``sin(elevation) >= xi``) give NaN.
    """
    _check_spec(spec)
    a = np.asarray(azimuth, dtype=np.float64)
    e = np.asarray(elevation, dtype=np.float64)
    # Point on the unit sphere in the mirror frame: z points from the mirror down to the
    # camera, the heading is image up (-v), the rover's left is image right (+u).
    cos_e = np.cos(e)
    xs, ys, zs = cos_e * np.sin(a), -cos_e * np.cos(a), -np.sin(e)
    depth = zs + spec.xi
    with np.errstate(divide="ignore", invalid="ignore"):
        scale = np.where(depth > 0.0, spec.gamma / depth, np.nan)
    return spec.cx + scale * xs, spec.cy + scale * ys


def lift(
    spec: MirrorSpec, u: ArrayLike, v: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Direction ``(azimuth, elevation)`` (radians) seen at pixel ``(u, v)``: the inverse of
    :func:`project`.

    Azimuth is in ``(-pi, pi]``, counter-clockwise from the heading; elevation in
    ``[-pi/2, asin(xi))``. The image centre gives azimuth 0 and elevation -pi/2. Pixels outside
    the mirror's disc still get the model's direction (check against
    :attr:`MirrorSpec.disc_radii` where that matters).
    """
    _check_spec(spec)
    mx = (np.asarray(u, dtype=np.float64) - spec.cx) / spec.gamma
    my = (np.asarray(v, dtype=np.float64) - spec.cy) / spec.gamma
    rho2 = mx * mx + my * my
    xi = spec.xi
    # the sphere point on the viewing ray from (0, 0, -xi) with the larger depth (the one the
    # mirror shows): depth = factor > 0
    factor = (xi + np.sqrt(1.0 + (1.0 - xi * xi) * rho2)) / (rho2 + 1.0)
    xs, ys, zs = factor * mx, factor * my, factor - xi
    azimuth = np.arctan2(xs, -ys)
    elevation = np.arctan2(-zs, np.hypot(xs, ys))
    return azimuth, elevation


# -- remap tables -------------------------------------------------------------------------------


@functools.lru_cache(maxsize=8)
def _circular_maps(spec: MirrorSpec) -> tuple[NDArray[Any], NDArray[Any], NDArray[np.uint8]]:
    """Fixed-point remap tables from the view panorama to the circular image, and the disc's
    mask ``(S, S, 3)`` (255 inside the mirror's annulus, 0 outside)."""
    view = spec.view_spec()
    size = spec.image_size
    v, u = np.mgrid[0:size, 0:size].astype(np.float64)
    azimuth, elevation = lift(spec, u, v)
    # View panorama: column c looks at azimuth 2*pi*c/W, row r at vfov/2 - (r + 1/2) vfov/H.
    vfov = math.radians(view.vfov_deg)
    map_x = np.mod(azimuth, 2.0 * np.pi) * (view.width / (2.0 * np.pi))
    map_y = (vfov / 2.0 - elevation) * (view.height / vfov) - 0.5
    radius = np.hypot(u - spec.cx, v - spec.cy)
    inner, outer = spec.disc_radii
    inside = (radius >= inner) & (radius <= outer)
    # Outside the disc: any row of the panorama (the mask blacks it out); keeps BORDER_WRAP
    # from folding the sky onto the ground.
    map_y = np.where(inside, map_y, view.height / 2.0)
    mask = np.repeat(np.where(inside, 255, 0).astype(np.uint8)[:, :, None], 3, axis=2)
    fixed_x, fixed_y = cv2.convertMaps(
        map_x.astype(np.float32), map_y.astype(np.float32), cv2.CV_16SC2
    )
    return fixed_x, fixed_y, mask


@functools.lru_cache(maxsize=8)
def _row_radii(spec: MirrorSpec, rows: int) -> NDArray[np.float64]:
    """Circular-image radius of each of ``rows`` unwarped rows, top (the rim's side) first."""
    fraction = (np.arange(rows) + 0.5) / rows  # 0 at the top edge, 1 at the bottom edge
    if spec.unwarp_rows == "radius":
        bottom, top = spec.unwarp_radii
        return top + (bottom - top) * fraction
    low, high = (math.radians(e) for e in spec.unwarp_elevation_deg)
    return _radius(spec.xi, spec.gamma, high + (low - high) * fraction)


def _unwarp_maps(spec: MirrorSpec) -> tuple[NDArray[Any], NDArray[Any]]:
    """Fixed-point remap tables from the circular image to the supersampled panorama."""
    s = spec.supersample
    rows, cols = spec.panorama_height * s, spec.panorama_width * s
    # Sub-pixel centres: after the s x s box filter, column c is centred on azimuth 2*pi*c/W.
    azimuth = 2.0 * np.pi / spec.panorama_width * ((np.arange(cols) + 0.5) / s - 0.5)
    radius = _row_radii(spec, rows)
    dx, dy = spec.unwarp_centre_offset
    # Same orientation as project(): heading up, counter-clockwise azimuth clockwise on screen.
    map_x = spec.cx + dx + radius[:, None] * np.sin(azimuth)[None, :]
    map_y = spec.cy + dy - radius[:, None] * np.cos(azimuth)[None, :]
    return cv2.convertMaps(map_x.astype(np.float32), map_y.astype(np.float32), cv2.CV_16SC2)


def vignetting_gain(
    spec: MirrorSpec, rim_loss: float, circular: bool = False
) -> NDArray[np.float32]:
    """Relative illumination of each pixel of the unwarped panorama ``(H, W)`` (or, with
    ``circular``, of the circular image ``(S, S)``): ``cos^4`` of the angle between the lens's
    axis and the ray that reaches the pixel's radius in the circular image. The lens's focal
    length is the one that loses ``rim_loss`` of the light at the mirror's rim; the unwarped
    pixels' radii are measured from the true centre (the unwarp's may be off it)."""
    if not 0.0 <= rim_loss < 1.0:
        raise ValueError(f"rim_loss must be in [0, 1), got {rim_loss!r}")
    rim = spec.disc_radii[1]
    # cos^4(theta) = 1 / (1 + (r / f)^2)^2 equals 1 - rim_loss at the rim
    reach = math.sqrt(1.0 / math.sqrt(1.0 - rim_loss) - 1.0) / rim  # 1 / f
    if circular:
        v, u = np.mgrid[0 : spec.image_size, 0 : spec.image_size].astype(np.float64)
        radius = np.hypot(u - spec.cx, v - spec.cy)
    else:
        height, width = spec.panorama_height, spec.panorama_width
        azimuth = 2.0 * np.pi * np.arange(width) / width
        rows = _row_radii(spec, height)
        dx, dy = spec.unwarp_centre_offset
        radius = np.hypot(
            dx + rows[:, None] * np.sin(azimuth)[None, :], dy - rows[:, None] * np.cos(azimuth)
        )
    return (1.0 / (1.0 + (radius * reach) ** 2) ** 2).astype(np.float32)


def unwarp(circular: NDArray[np.uint8], spec: MirrorSpec) -> NDArray[np.uint8]:
    """Unwarp a circular mirror image to a panorama (polar unwarp, one ``cv2.remap``).

    Works on real mirror images too: crop the image to a square around the mirror, turn it so
    that the heading points up, and set ``spec``'s image size, centre, ``xi`` and ``gamma`` to
    the camera's (or any that put ``unwarp_elevation_deg`` at the wanted radii).

    Args:
        circular: ``(S, S, 3)`` uint8 RGB, ``S = spec.image_size``; the rover's heading up.
        spec: the camera and the unwarp.
    Returns:
        ``(H, W, 3)`` uint8 RGB, a new C-contiguous array: column ``c`` looks at azimuth
        ``heading + 2*pi*c/W`` counter-clockwise, row 0 is the top of the unwarp range.
    """
    _check_spec(spec)
    image = np.asarray(circular)
    if image.dtype != np.uint8:
        raise TypeError(f"circular must be a uint8 image, got dtype {image.dtype}")
    if image.shape != spec.circular_shape:
        raise ValueError(
            f"circular must have shape {spec.circular_shape} (spec.image_size), got {image.shape}"
        )
    map_x, map_y = _unwarp_maps(spec)
    fine = cv2.remap(image, map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT)
    if spec.supersample == 1:
        return fine
    size = (spec.panorama_width, spec.panorama_height)
    return cv2.resize(fine, size, interpolation=cv2.INTER_AREA)


# -- the camera ---------------------------------------------------------------------------------


class MirrorCamera:
    """Renders the circular image of a catadioptric camera and its unwarped panorama.

    Holds an :class:`~sfa_gym.sim.camera.renderer.OmniCamera` of ``spec.view_spec()``; like
    it, construction is cheap and the GL context is created on the first render (see its
    notes on processes). One :meth:`render` = one view panorama + two precomputed remaps.

    Args:
        model: MuJoCo model whose mast carries ``camera_mjcf(spec.view_spec(), prefix)``
            (``rover_mjcf(rover, spec.view_spec())`` builds them).
        spec: the mirror camera.
        prefix: camera name prefix.
    Raises:
        TypeError: ``spec`` is not a MirrorSpec.
        ValueError: the model's cameras do not match ``spec.view_spec()``.
    """

    def __init__(self, model: mujoco.MjModel, spec: MirrorSpec, prefix: str = "omni") -> None:
        # Imported here so that the geometry above works without MuJoCo and OpenGL.
        from sfa_gym.sim.camera.renderer import OmniCamera

        self.spec = _check_spec(spec)
        self.model = model
        self.prefix = prefix
        self.view_camera = OmniCamera(model, spec.view_spec(), prefix)

    def render_view(self, data: mujoco.MjData) -> NDArray[np.uint8]:
        """The cylindrical view panorama, ``spec.view_spec()``'s ``(H, W, 3)`` uint8."""
        return self.view_camera.render(data)

    def render_circular(self, data: mujoco.MjData) -> NDArray[np.uint8]:
        """The circular mirror image, ``(S, S, 3)`` uint8 RGB, heading up; black outside the
        mirror's annulus (:attr:`MirrorSpec.disc_radii`)."""
        view = self.view_camera.render(data)
        map_x, map_y, mask = _circular_maps(self.spec)
        # The panorama is periodic in width; outside the disc the mask blacks out the samples.
        image = cv2.remap(view, map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_WRAP)
        return cv2.bitwise_and(image, mask)

    def render(
        self,
        data: mujoco.MjData,
        sensor: Callable[[NDArray[np.uint8]], NDArray[np.uint8]] | None = None,
    ) -> NDArray[np.uint8]:
        """The unwarped panorama, ``(H, W, 3)`` uint8 RGB (``spec.panorama_shape``).

        Args:
            data: simulation state (call ``mj_forward`` after moving things).
            sensor: optional effects of the camera's sensor (exposure, gain, noise), applied
                to the circular image before the unwarp: they act on the camera's pixels, and
                the unwarp then spreads and correlates them as it does on a real robot. It
                takes and returns an ``(S, S, 3)`` uint8 image.
        """
        circular = self.render_circular(data)
        if sensor is not None:
            circular = sensor(circular)
        return unwarp(circular, self.spec)

    def close(self) -> None:
        """Free the GL context; safe to call more than once."""
        self.view_camera.close()
