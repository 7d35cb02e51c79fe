"""Omnidirectional panoramic camera: N pinhole views stitched into one cylindrical panorama.

The rover's mast carries ``n_views`` MuJoCo cameras (built by :func:`camera_mjcf`) that look
horizontally at evenly spaced azimuths; they fix the eye, the mast's frame and the views' field
of view. :class:`OmniCamera` renders ``n_views`` pinhole views into the viewports of one
offscreen buffer, reads the buffer once and resamples it with one ``cv2.remap`` onto the
panorama grid:

* column ``c`` looks at azimuth ``heading + 2*pi*c/W`` (counter-clockwise, so a yaw change of
  ``+2*pi*k/W`` gives ``np.roll(old, -k, axis=1)``); the panorama is periodic in width;
* row ``r`` looks at elevation ``vfov/2 - (r + 1/2) * vfov/H`` (row 0 is the top; rows are
  equiangular in elevation, centred on the horizon).

Anti-aliasing is by supersampling: the views are rendered ``supersample`` times denser than the
panorama (at the centre of a view; denser towards its sides), the panorama is resampled at
``supersample`` times its resolution and box-filtered down (``cv2.INTER_AREA``). On a CPU
rasteriser this is cheaper than MSAA.

Which way the views look (``PanoramaSpec.views``). A rasteriser point-samples each view, so an
edge is anti-aliased according to where it falls in the view's pixel grid, and a pinhole view's
pixel footprint on the cylinder changes with the azimuth inside the view (vertically by
``1/cos``). Views that turn with the rover ("rover") therefore render the same scene
differently at every heading that is not a multiple of ``360/n_views`` degrees: edges near the
horizon differed by 8-12 grey levels (row means) after shifting back, and the slow features of
one position wobbled with the heading as much as they change over 0.1 m. With "compass" (the
default) the views look along fixed compass directions, world +x, +y, ..., levelled with the
mast, so their pixels do not depend on the heading; each panorama column is resampled from them
at its own compass azimuth ``heading + 2*pi*c/W``. Turning by whole columns then shifts the
panorama exactly; the fraction of a column (quantised to 1/32 of a supersampled pixel, the
resolution of ``cv2.remap``'s fixed-point maps) moves the resampling positions, as a real
sensor's pixels move over the image. ``eval/studies/camera_equivariance.py`` measures both.

What the views see: the model's geoms of groups 0-2 (MuJoCo's default), no sites, no shadows or
reflections. A headlight is moved to the eye and made to shine in all directions, so that every
view lights a surface alike (a headlight along each view's axis would leave seams).

Cost (llvmpipe, CPU only): rasterising the views' pixels dominates, then MuJoCo's and the
driver's work per drawn geom; readback and resampling are a few per cent. Each view draws only
the geoms whose bounding sphere meets its frustum, and a skybox as smooth as MuJoCo's builtin
gradient is sampled from its nearest texel instead of trilinearly (the sky's cube-map lookups
were a third of the cost; the pixels stay within one grey level). ``eval/benchmarks/bench_env.py``
measures it all.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal, get_args

import numpy as np
from numpy.typing import NDArray

from sfa_gym._checks import check_int_in

__all__ = ["PanoramaSpec", "ViewDirections", "camera_mjcf"]

ViewDirections = Literal["compass", "rover"]
"""Where the pinhole views look: fixed compass directions, or along the rover's heading."""

# Elevation (degrees) that every view covers beyond the panorama's top and bottom edges, so that
# bilinear samples of the outermost rows stay inside the rendered image.
_ELEVATION_MARGIN_DEG = 1.0
# Pixels on each side of a view beyond its azimuth sector, for the same reason.
_SIDE_MARGIN_PX = 1.5
# The views' fovy grows like tan(vfov/2) and reaches 180 degrees at vfov = 180.
_MAX_VFOV_DEG = 150.0
_MAX_VIEWS = 64
_MAX_SUPERSAMPLE = 8
# A skybox whose neighbouring texels differ by at most this many grey levels (a smooth gradient,
# like MuJoCo's builtin "gradient" sky at 256 texels a face) is sampled without filtering; see
# _smooth_skyboxes.
_SMOOTH_SKY_STEP = 1


@dataclass(frozen=True)
class PanoramaSpec:
    """Geometry and quality of a cylindrical panorama.

    Attributes:
        width: panorama columns ``W`` (pixels over 360 degrees of azimuth), >= 1.
        height: panorama rows ``H``, >= 1.
        vfov_deg: vertical field of view of the cylinder in degrees, centred on the horizon,
            in (0, 150].
        n_views: pinhole cameras around the mast, in [3, 64]; each covers 360/n degrees.
        supersample: render and resample at this factor, then box-filter down, in [1, 8]
            (1 = no anti-aliasing).
        views: "compass" (default): the views look along fixed compass directions and each
            column is resampled at its own compass azimuth, so that turning by whole columns
            shifts the panorama exactly; "rover": the views turn with the rover (the camera of
            sfa-gym 0.1, kept to reproduce its figures; not rotation-equivariant).
    """

    width: int = 350
    height: int = 40
    vfov_deg: float = 40.0
    n_views: int = 4
    supersample: int = 2
    views: ViewDirections = "compass"

    def __post_init__(self) -> None:
        check_int_in("PanoramaSpec.width", self.width, 1, 1 << 16)
        check_int_in("PanoramaSpec.height", self.height, 1, 1 << 16)
        check_int_in("PanoramaSpec.n_views", self.n_views, 3, _MAX_VIEWS)
        check_int_in("PanoramaSpec.supersample", self.supersample, 1, _MAX_SUPERSAMPLE)
        vfov = self.vfov_deg
        if isinstance(vfov, bool) or not isinstance(vfov, int | float | np.integer | np.floating):
            raise ValueError(f"PanoramaSpec.vfov_deg must be a number, got {vfov!r}")
        if not 0.0 < float(vfov) <= _MAX_VFOV_DEG:
            raise ValueError(
                f"PanoramaSpec.vfov_deg must be in (0, {_MAX_VFOV_DEG:g}] degrees, got {vfov!r}"
            )
        if self.views not in get_args(ViewDirections):
            raise ValueError(
                f"PanoramaSpec.views must be one of {list(get_args(ViewDirections))}, "
                f"got {self.views!r}"
            )

    @classmethod
    def paper_sim(cls) -> PanoramaSpec:
        """The paper's simulator panoramas: 350 x 40 pixels."""
        return cls(width=350, height=40)

    @classmethod
    def paper_outdoor(cls) -> PanoramaSpec:
        """The paper's outdoor panoramas: 600 x 60 pixels."""
        return cls(width=600, height=60)


def _view_fovy_deg(spec: PanoramaSpec) -> float:
    """Vertical fovy (degrees) of each pinhole view.

    A view covers azimuths within ``pi/N`` of its axis; at the sector edge a point at elevation
    ``e`` projects to image height ``tan(e) / cos(pi/N)`` (focal length 1), so that is what the
    fovy must reach.
    """
    top = math.radians(spec.vfov_deg / 2.0 + _ELEVATION_MARGIN_DEG)
    return math.degrees(2.0 * math.atan(math.tan(top) / math.cos(math.pi / spec.n_views)))


def _view_azimuths(spec: PanoramaSpec) -> NDArray[np.float64]:
    return 2.0 * np.pi * np.arange(spec.n_views) / spec.n_views


def camera_mjcf(spec: PanoramaSpec, prefix: str = "omni") -> str:
    """MJCF ``<camera>`` elements of the omnidirectional camera, to put inside the mast body.

    Camera ``f"{prefix}{i}"`` sits at the body origin and looks horizontally along azimuth
    ``2*pi*i/n_views`` counter-clockwise from the body's +x axis (the heading), image up = body
    +z. MuJoCo cameras look along their local -z with +y up, hence the ``xyaxes``. Only
    ``spec.vfov_deg`` and ``spec.n_views`` shape the elements.

    Args:
        spec: the panorama the cameras are for.
        prefix: camera name prefix (no spaces or quotes).
    Returns:
        The elements, one per line.
    """
    if not isinstance(spec, PanoramaSpec):
        raise TypeError(f"spec must be a PanoramaSpec, got {type(spec).__name__}")
    if not isinstance(prefix, str) or not prefix or any(ch in prefix for ch in "<>\"'& \t\n"):
        raise ValueError(
            f"prefix must be a non-empty name without spaces or quotes, got {prefix!r}"
        )
    fovy = _view_fovy_deg(spec)
    lines = []
    for i, azimuth in enumerate(_view_azimuths(spec)):
        # Rounding turns cos(pi/2) = 6e-17 into a clean 0 (and -0.0 into 0).
        c, s = (round(v, 12) + 0.0 for v in (math.cos(azimuth), math.sin(azimuth)))
        # Image right = forward x up = (sin a, -cos a, 0); image up = +z.
        lines.append(
            f'<camera name="{prefix}{i}" pos="0 0 0" '
            f'xyaxes="{s:.12g} {-c + 0.0:.12g} 0 0 0 1" fovy="{fovy:.15g}"/>'
        )
    return "\n".join(lines)


@dataclass(frozen=True)
class _Layout:
    """Pixel geometry of the views in the offscreen buffer.

    ``focal``: pinhole focal length in pixels; ``view_w`` x ``view_h``: one viewport; the views
    sit on a grid of ``cols`` columns, view ``i`` at ``((i % cols) * view_w, (i // cols) *
    view_h)`` in OpenGL window coordinates (origin bottom-left).
    """

    focal: float
    view_w: int
    view_h: int
    n_views: int
    cols: int

    @property
    def rows(self) -> int:
        return -(-self.n_views // self.cols)

    @property
    def buffer_w(self) -> int:
        return self.view_w * self.cols

    @property
    def buffer_h(self) -> int:
        return self.view_h * self.rows

    def origin(self, view: int) -> tuple[int, int]:
        return (view % self.cols) * self.view_w, (view // self.cols) * self.view_h


def _layout(spec: PanoramaSpec, fovy_deg: float) -> _Layout:
    """Smallest views whose central pixel density matches the supersampled panorama's."""
    vfov = math.radians(spec.vfov_deg)
    # Supersampled panorama pixels per radian; a pinhole view is densest at its sides, so
    # matching at its centre never undersamples.
    density = spec.supersample * max(spec.width / (2.0 * math.pi), spec.height / vfov)
    half_fovy = math.tan(math.radians(fovy_deg) / 2.0)
    view_h = 2 * math.ceil(density * half_fovy)
    focal = (view_h / 2.0) / half_fovy
    view_w = 2 * math.ceil(focal * math.tan(math.pi / spec.n_views) + _SIDE_MARGIN_PX)
    # The squarest grid keeps the buffer within OpenGL's size limits for large panoramas.
    n = spec.n_views
    cols = min(range(1, n + 1), key=lambda c: (max(c * view_w, -(-n // c) * view_h), -c))
    return _Layout(focal=focal, view_w=view_w, view_h=view_h, n_views=n, cols=cols)


def heading_phases(spec: PanoramaSpec) -> int:
    """Steps per panorama column in which a compass camera resolves the heading: 1/32 of a
    supersampled pixel, the resolution of ``cv2.remap``'s fixed-point maps."""
    return 32 * spec.supersample


def _remap_tables(
    spec: PanoramaSpec, layout: _Layout, phase: int = 0
) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
    """Source coordinates in the read-back buffer for every supersampled panorama pixel.

    Column 0 of the panorama looks ``phase / heading_phases(spec)`` of a column
    counter-clockwise of view 0's axis (0: along it, as for views that turn with the rover).

    Returns ``(map_x, map_y)``, each ``(H*s, W*s)`` float32, in buffer pixels (pixel centres at
    integers). The buffer comes from ``glReadPixels``: its row 0 is the bottom of the image, so
    a higher elevation means a larger row index and no flip is needed.
    """
    s = spec.supersample
    rows, cols = spec.height * s, spec.width * s
    # Sub-pixel centres: after the s x s box filter, output column c is centred on azimuth
    # 2*pi*c/W (plus the phase) exactly, and the rows are symmetric about the horizon.
    offset = phase / heading_phases(spec)
    azimuth = 2.0 * np.pi / spec.width * ((np.arange(cols) + 0.5) / s - 0.5 + offset)
    vfov = math.radians(spec.vfov_deg)
    tan_elevation = np.tan(vfov / 2.0 - (np.arange(rows) + 0.5) * vfov / rows)
    sector = 2.0 * np.pi / spec.n_views
    view = np.round(azimuth / sector).astype(np.int64) % spec.n_views
    theta = azimuth - view * sector  # from the view's axis, counter-clockwise
    theta = (theta + np.pi) % (2.0 * np.pi) - np.pi
    f = layout.focal
    # Counter-clockwise of the axis is to the left in the image.
    x_in_view = layout.view_w / 2.0 - 0.5 - f * np.tan(theta)
    scale = f / np.cos(theta)  # image rows per unit of tan(elevation)
    y_top = layout.view_h / 2.0 - 0.5 + tan_elevation[0] * scale
    y_bottom = layout.view_h / 2.0 - 0.5 + tan_elevation[-1] * scale
    inside = (
        x_in_view.min() >= 0.0
        and x_in_view.max() <= layout.view_w - 1.0
        and y_bottom.min() >= 0.0
        and y_top.max() <= layout.view_h - 1.0
    )
    if not inside:
        raise RuntimeError(f"panorama samples fall outside the rendered views ({spec}, {layout})")
    x0 = (view % layout.cols) * layout.view_w
    y0 = (view // layout.cols) * layout.view_h + layout.view_h / 2.0 - 0.5
    map_y = (y0 + tan_elevation[:, None] * scale).astype(np.float32)
    map_x = np.empty_like(map_y)
    map_x[:] = (x0 + x_in_view).astype(np.float32)
    return map_x, map_y
