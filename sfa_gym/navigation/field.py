"""Feature fields: a feature model's rotation-averaged features over a grid of positions, so that
navigation in a static world can read them without rendering.

(Longer than 550 lines on purpose: the builder, the interpolation tables and the file format
share the grid's conventions and are read together; the checks of an untrusted file are a
third of it.)

In a static world the features of a place (:func:`sfa_gym.features.rotation_averaged_features`,
averaged over every column, ``step=1``) depend on the rover's position only: the compass camera
turns the panorama by whole columns exactly (a turn by ``+2*pi*k/W`` shifts it by ``-k`` columns),
and the average over all ``W`` shifts does not change under such a shift; a turn by a fraction of a
column changes it slightly (``eval/benchmarks/bench_field.py`` measures how much). A field is
therefore rendered once per grid node, facing yaw 0, and **ignores the heading**. Rendering a
panorama costs ~8-11 ms; a query of the field costs microseconds, so an env that steps physics
only can run thousands of steps per second.

Grid. The nodes cover the drivable area ``(xmin, xmax, ymin, ymax)`` including its edges:
``xs = linspace(xmin, xmax, nx)`` with ``nx = ceil((xmax - xmin) / spacing) + 1`` (likewise
``ys``), so the node spacing is the requested spacing when it divides the extent and a little
less otherwise. ``values[j, i]`` holds the features at ``(xs[i], ys[j])``. Nodes that are not
free (inside obstacles) are not rendered; they take the features of the nearest free node, so
that interpolation next to an obstacle does not pull towards meaningless values.

Interpolation. Within each cell the field is a polynomial in the cell's local coordinates
``u, v`` in ``[0, 1]``, precomputed for every cell, so a query is a table lookup and a dot
product (:meth:`FeatureField.at`, the single-point path, ~3 us; ``field(points)``, the
vectorised one). All three methods pass through the node values exactly:

- ``"catmull-rom"`` (default): the local bicubic Catmull-Rom interpolant (slopes from central
  differences; the node beyond an edge is extrapolated linearly). Continuous with a continuous
  gradient; a cell depends on its 4 x 4 surrounding nodes only.
- ``"linear"``: bilinear. Continuous; the gradient jumps at cell borders.
- ``"cubic"``: the tensor-product interpolating cubic spline with not-a-knot ends (twice
  continuously differentiable, global; an axis of fewer than 4 nodes gets the highest degree
  its nodes allow).

Points outside the grid are clamped to it. ``eval/benchmarks/bench_field.py`` compares the
methods with rendered features at 200 random poses (the ``paper_sim`` network,
``published/benchmarks/field.json``): the median distance between field and rendering is 0.334 /
0.338 / 0.353 (linear / Catmull-Rom / cubic) of the features' mean change over 0.1 m at 0.1 m
spacing, 0.205 / 0.208 / 0.224 at 0.05 m. Catmull-Rom is as close as bilinear and has a continuous
gradient, which a controller or agent following the gradient needs; the spline is further off (it
overshoots). The error is set by the rendered features' own roughness below the node spacing, not by
the interpolation: over 1 cm they change by 0.039 in the median but 0.065 on average (a heavy tail
of small jumps, e.g. when an edge crosses a pixel row), and the error shrinks roughly like the
square root of the spacing. The spread over headings (step 1) is ~0.05 of the change over 0.1 m.

File format (version 1): one ``.npz`` archive as ``np.savez`` writes it (uncompressed), written
atomically and read, never unpickled, by :func:`sfa_gym.files.write_npz` and
:func:`~sfa_gym.files.read_npz`:

- ``header``: 0-d unicode array holding a JSON object::

      {"format": "sfa-gym-feature-field", "version": 1,
       "shape": [ny, nx, k], "bounds": [xmin, xmax, ymin, ymax], "interpolation": "catmull-rom",
       "metadata": {"world": "paper_sim", "world_hash": "sha256:...", "world_seed": 0,
                    "panorama": {...}, "panorama_height": 40, "panorama_width": 350,
                    "spacing": 0.1, "node_spacing": [0.1, 0.1], "step": 1, "heading": 0.0,
                    "n_features": 8, "n_free": 3721, "model_info": ...,
                    "sfa_gym_version": "0.1.0", "created": "2026-...", ...}}

  ``metadata`` is free-form for a field built by hand; :meth:`FeatureField.build` writes the
  keys above (``world_hash``: SHA-256 of the world spec as canonical JSON; ``model_info``:
  whatever the caller passed to describe the model; ``sfa-gym navigate`` writes ``method``,
  ``cost_weights``, the gradient controller's feature weights, and ``weight_power``).
- ``values``: ``(ny, nx, k)`` float64, the features at the nodes (non-free nodes filled).
- ``free``: ``(ny, nx)`` bool, the nodes that were rendered.

No other member is allowed. :meth:`FeatureField.load` checks every member's ``.npy`` header
(dtype, shape and size against the JSON header) before reading any data.
"""

from __future__ import annotations

import dataclasses
import datetime
import hashlib
import json
import math
import os
import time
from collections.abc import Callable
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sfa_gym._checks import FEATURE_BOUND, check_positive_int
from sfa_gym.features import rotation_averaged_features
from sfa_gym.files import load_error, read_npz, strict_json, write_npz

__all__ = [
    "FORMAT",
    "FORMAT_VERSION",
    "INTERPOLATIONS",
    "FeatureField",
    "fill_from_free",
    "world_hash",
]

FORMAT = "sfa-gym-feature-field"
FORMAT_VERSION = 1
INTERPOLATIONS = ("linear", "catmull-rom", "cubic")
"""Interpolation between nodes: bilinear, Catmull-Rom (local bicubic), the bicubic spline."""
_DEGREE = {"linear": 1, "catmull-rom": 3, "cubic": 3}


def world_hash(spec: Any) -> str | None:
    """``"sha256:<hex>"`` of a world spec (a dataclass) as canonical JSON; None for another
    object. Two envs with the same hash and world seed build the same world."""
    if not dataclasses.is_dataclass(spec) or isinstance(spec, type):
        return None
    text = json.dumps(dataclasses.asdict(spec), sort_keys=True, separators=(",", ":"))
    return "sha256:" + hashlib.sha256(text.encode()).hexdigest()


WORLD_KEYS = ("world", "world_hash", "world_seed", "panorama")
"""The metadata keys that say which world and camera a field was built from."""


def _env_description(env: Any) -> dict[str, Any]:
    """What identifies the rendered world and camera: world name, spec hash, seed, panorama."""
    spec = getattr(env, "world_spec", None)
    panorama = getattr(env, "panorama", None)
    shape = getattr(getattr(env, "observation_space", None), "shape", None)
    return {
        "world": getattr(spec, "name", None),
        "world_hash": world_hash(spec),
        "world_seed": getattr(env, "world_seed", None),
        "panorama": dataclasses.asdict(panorama) if dataclasses.is_dataclass(panorama) else None,
        "panorama_height": int(shape[0]) if shape is not None else None,
        "panorama_width": int(shape[1]) if shape is not None else None,
    }


def _grid_axis(lo: float, hi: float, spacing: float) -> NDArray[np.float64]:
    """Nodes from ``lo`` to ``hi`` inclusive, at most ``spacing`` apart, evenly spaced."""
    # the tolerance keeps 6.0 / 0.1 = 60.00000000000001 from adding a node
    n = math.ceil((hi - lo) / spacing - 1e-9) + 1
    return np.linspace(lo, hi, n)


def _check_spacing(spacing: Any, bounds: tuple[float, float, float, float]) -> float:
    if isinstance(spacing, bool) or not isinstance(spacing, int | float | np.integer | np.floating):
        raise TypeError(f"spacing must be a number (metres), got {spacing!r}")
    spacing = float(spacing)
    xmin, xmax, ymin, ymax = bounds
    smallest = min(xmax - xmin, ymax - ymin)
    if not (math.isfinite(spacing) and spacing > 0):
        raise ValueError(f"spacing must be a positive finite number of metres, got {spacing!r}")
    if spacing > smallest:
        raise ValueError(
            f"spacing {spacing!r} m is larger than the arena ({xmax - xmin:g} x {ymax - ymin:g} "
            "m): the grid needs at least two nodes per axis"
        )
    return spacing


def _catmull_rom(n: int, t: NDArray[np.float64]) -> NDArray[np.float64]:
    """``(len(t) * (n - 1), n)``: Catmull-Rom weights of the 4 nodes around each cell at the
    local coordinates ``t``; the missing node beyond each end is extrapolated linearly
    (``f[-1] = 2 f[0] - f[1]``), so an axis of 2 nodes is linear."""
    t2, t3 = t * t, t * t * t
    weights = np.stack(
        [
            (-t + 2 * t2 - t3) / 2,
            (2 - 5 * t2 + 3 * t3) / 2,
            (t + 4 * t2 - 3 * t3) / 2,
            (t3 - t2) / 2,
        ],
        axis=1,
    )  # (len(t), 4): nodes i - 1, i, i + 1, i + 2 of cell i
    ghosts = np.zeros((n + 2, n))  # node -1 .. n as combinations of the real nodes
    ghosts[1:-1] = np.eye(n)
    ghosts[0, :2] = (2, -1)
    ghosts[-1, -2:] = (-1, 2)
    # numpy's own loops, not BLAS (whose kernels differ per CPU): the same table everywhere
    cells = [np.einsum("tm,mn->tn", weights, ghosts[i : i + 4]) for i in range(n - 1)]
    return np.concatenate(cells)


def _interpolation_matrix(nodes: NDArray[np.float64], interpolation: str) -> NDArray[np.float64]:
    """``((d + 1) * (n - 1), n)``: the 1-d interpolant through data at ``nodes``, evaluated at
    ``d + 1`` evenly spaced points of every cell (``d`` its degree), as a linear map of the
    data."""
    from scipy.interpolate import make_interp_spline

    n, degree = len(nodes), _DEGREE[interpolation]
    t = np.linspace(0.0, 1.0, degree + 1)
    if interpolation == "catmull-rom":
        return _catmull_rom(n, t)
    # not-a-knot ends; a cubic needs 4 nodes, fewer give the highest degree they allow
    spline = make_interp_spline(nodes, np.eye(n), k=min(degree, n - 1))
    samples = (nodes[:-1, None] + t[None, :] * np.diff(nodes)[:, None]).ravel()
    return spline(samples)


def _vandermonde_inverse(n: int) -> NDArray[np.float64]:
    """The inverse of the ``n x n`` Vandermonde matrix ``t_a ** p`` at ``t = linspace(0, 1, n)``
    (row ``p``: the coefficient of ``t ** p`` from the ``n`` samples), solved in exact fractions
    and rounded once: the same on every CPU."""
    t = [Fraction(a, n - 1) if n > 1 else Fraction(0) for a in range(n)]
    identity = [[Fraction(int(a == b)) for b in range(n)] for a in range(n)]
    rows = [[t[a] ** p for p in range(n)] + identity[a] for a in range(n)]
    for c in range(n):  # Gauss-Jordan on [V | I]; exact, so no pivoting is needed beyond non-zero
        pivot = next(r for r in range(c, n) if rows[r][c] != 0)
        rows[c], rows[pivot] = rows[pivot], rows[c]
        rows[c] = [v / rows[c][c] for v in rows[c]]
        for r in range(n):
            if r != c and rows[r][c] != 0:
                rows[r] = [v - rows[r][c] * w for v, w in zip(rows[r], rows[c], strict=True)]
    # rows hold V^-1 with V[a, p] = t_a ** p: V^-1[p, a] maps samples to coefficients
    return np.array([[float(rows[p][n + a]) for a in range(n)] for p in range(n)])


_TABLE_BLOCK_BYTES = 64 * 2**20
"""Bytes of the intermediate samples :func:`_cell_polynomials` holds at a time: it fills the
table a block of cell rows at a time, so its peak is the table and one block, not four tables
(a navigation field of 420 features on the campus: a table of 0.5 GB)."""


def _cell_polynomials(
    values: NDArray[np.float64],
    xs: NDArray[np.float64],
    ys: NDArray[np.float64],
    interpolation: str,
    block_bytes: int = _TABLE_BLOCK_BYTES,
) -> NDArray[np.float64]:
    """Coefficients of the interpolant's polynomial in every cell.

    Returns:
        ``((ny - 1) * (nx - 1), (degree + 1) ** 2, k)`` float64: row ``j * (nx - 1) + i`` is
        cell ``[xs[i], xs[i+1]] x [ys[j], ys[j+1]]``, column ``p * (degree + 1) + q`` the
        coefficient of ``u**p * v**q`` with ``u = (x - xs[i]) / dx`` and ``v = (y - ys[j]) /
        dy``; built ``block_bytes`` of samples at a time.
    """
    degree = _DEGREE[interpolation]
    d1 = degree + 1
    ny, nx, k = values.shape
    # The spline is a polynomial of this degree within each cell, so its values at (d+1)^2
    # points of a cell determine the cell's coefficients exactly (a Vandermonde solve).
    mx, my = _interpolation_matrix(xs, interpolation), _interpolation_matrix(ys, interpolation)
    inverse = _vandermonde_inverse(d1)  # power <- sample
    # numpy's own einsum loops, one factor at a time, not BLAS (optimize=True would call it),
    # whose kernels differ per CPU: the same table, and so the same episodes, on every CPU.
    # Each block's elements are the same sums as the whole table's (tests/test_field.py).
    along_x = np.einsum("ti,jik->jtk", mx, values)  # (ny, sx, k)
    table = np.empty((ny - 1, nx - 1, d1, d1, k))
    rows = max(1, block_bytes // (d1 * (nx - 1) * d1 * k * 8))
    for j0 in range(0, ny - 1, rows):
        j1 = min(j0 + rows, ny - 1)
        samples = np.einsum("sj,jtk->stk", my[j0 * d1 : j1 * d1], along_x)
        # samples[j, b, i, a] is at v = t[b], u = t[a]; coefficients [j, i, p (u), q (v)]
        samples = samples.reshape(j1 - j0, d1, nx - 1, d1, k)
        along_u = np.einsum("pa,jbiak->jbipk", inverse, samples)
        table[j0:j1] = np.einsum("qb,jbipk->jipqk", inverse, along_u)
    # the node values themselves, not their rounded reconstruction: exact at the nodes
    table[:, :, 0, 0] = values[:-1, :-1]
    return table.reshape((ny - 1) * (nx - 1), d1 * d1, k)


def fill_from_free(
    values: NDArray[np.float64],
    free: NDArray[np.bool_],
    xs: NDArray[np.float64],
    ys: NDArray[np.float64],
) -> NDArray[np.float64]:
    """``values (ny, nx, k)`` of a field's nodes with each non-free node (``free (ny, nx)``
    False) given the features of the nearest free node (in metres, nodes at ``xs``, ``ys``)."""
    if free.all():
        return values
    from scipy.ndimage import distance_transform_edt

    _, (iy, ix) = distance_transform_edt(
        ~free, sampling=(ys[1] - ys[0], xs[1] - xs[0]), return_indices=True
    )
    return values[iy, ix]


class FeatureField:
    """Features of a feature model over a grid of positions, interpolated between the nodes.

    Build one from an env and a fitted model with :meth:`build`, read one with :meth:`load`,
    query it with ``field(points)`` or :meth:`at`. The field ignores the heading (see the module
    docstring).

    Args:
        values: ``(ny, nx, k)`` features at the nodes; ``values[j, i]`` at ``(xs[i], ys[j])``,
            ``nx, ny >= 2``, finite.
        bounds: ``(xmin, xmax, ymin, ymax)`` in metres: the first and last node of each axis;
            the nodes are evenly spaced in between.
        free: ``(ny, nx)`` bool, the nodes that were rendered (None: all).
        metadata: JSON-serialisable description (world, camera, model; see the module
            docstring); stored with the field.
        interpolation: ``"catmull-rom"`` (default), ``"linear"`` or ``"cubic"`` (see the module
            docstring).

    Attributes:
        values, free, bounds, metadata, interpolation: as given (arrays read-only).
        xs: ``(nx,)`` node x coordinates (m). ys: ``(ny,)`` node y coordinates (m).
        spacing: ``(dx, dy)`` node spacing (m).
        n_features: ``k``.
    """

    def __init__(
        self,
        values: ArrayLike,
        bounds: tuple[float, float, float, float],
        *,
        free: ArrayLike | None = None,
        metadata: dict[str, Any] | None = None,
        interpolation: str = "catmull-rom",
    ) -> None:
        values = np.array(values, dtype=np.float64)
        if values.ndim != 3 or values.shape[0] < 2 or values.shape[1] < 2 or values.shape[2] < 1:
            raise ValueError(
                f"values must be (ny, nx, k) with ny, nx >= 2 and k >= 1, got shape {values.shape}"
            )
        if not np.all(np.isfinite(values)):
            raise ValueError("values must be finite")
        if values.size and float(np.max(np.abs(values))) > FEATURE_BOUND:
            raise ValueError(
                f"values reach a magnitude of {float(np.max(np.abs(values))):.3g}; features must "
                f"stay within {FEATURE_BOUND:g} (beyond it the look-ups overflow)"
            )
        try:
            xmin, xmax, ymin, ymax = (float(b) for b in bounds)
        except (TypeError, ValueError):
            raise ValueError(f"bounds must be (xmin, xmax, ymin, ymax), got {bounds!r}") from None
        if not (all(map(math.isfinite, (xmin, xmax, ymin, ymax))) and xmin < xmax and ymin < ymax):
            raise ValueError(f"bounds must be finite with xmin < xmax and ymin < ymax: {bounds!r}")
        ny, nx, k = values.shape
        free = np.ones((ny, nx), bool) if free is None else np.array(free, dtype=bool)
        if free.shape != (ny, nx):
            raise ValueError(f"free must have shape {(ny, nx)}, got {free.shape}")
        if interpolation not in INTERPOLATIONS:
            raise ValueError(
                f"interpolation must be one of {INTERPOLATIONS}, got {interpolation!r}"
            )
        values.flags.writeable = False
        free.flags.writeable = False
        self.values = values
        self.free = free
        self.bounds = (xmin, xmax, ymin, ymax)
        self.metadata = dict(metadata or {})
        self.from_file: Path | None = None
        """the file the field was read from (:meth:`load`), or None"""
        self.interpolation = interpolation
        self.xs = np.linspace(xmin, xmax, nx)
        self.ys = np.linspace(ymin, ymax, ny)
        self.spacing = ((xmax - xmin) / (nx - 1), (ymax - ymin) / (ny - 1))
        self.n_features = k
        self._degree = _DEGREE[interpolation]
        self._table = _cell_polynomials(values, self.xs, self.ys, interpolation)
        # the single-point path reads plain Python floats: no numpy scalars per query
        self._x0, self._y0 = xmin, ymin
        self._inv_dx, self._inv_dy = 1.0 / self.spacing[0], 1.0 / self.spacing[1]
        self._umax, self._vmax = float(nx - 1), float(ny - 1)
        self._cells_x, self._cells_y = nx - 1, ny - 1

    # -- construction --------------------------------------------------------------------------

    @classmethod
    def build(
        cls,
        env: Any,
        model: Any,
        spacing: float = 0.1,
        step: int = 1,
        free: Callable[[NDArray[np.float64]], ArrayLike] | None = None,
        batch: int = 256,
        progress: bool = True,
        model_info: Any = None,
        interpolation: str = "catmull-rom",
    ) -> FeatureField:
        """Render the panorama at every free grid node (yaw 0) and average the model's features
        over its simulated rotations.

        Args:
            env: an :class:`~sfa_gym.sim.env.OmniRoverEnv` (a wrapped env is unwrapped): its
                :attr:`arena_bounds` are the grid's extent; ``env.reset(options={"pose": (x, y,
                0.0)})`` renders a node. The env is left at the last node.
            model: a fitted feature model for the env's panoramas (see
                :func:`~sfa_gym.features.rotation_averaged_features`).
            spacing: largest node spacing (m), ``0 < spacing <=`` the arena's smaller side.
            step: rotation step (columns) of the average; must divide the panorama width.
                ``1`` (every column) makes the features invariant to turns by whole columns.
            free: ``points (n, 2) -> (n,) bool``: which nodes lie outside obstacles (None: all);
                the others are filled from the nearest free node.
            batch: panoramas rendered and transformed at a time (bounds the memory: ~42 kB a
                panorama at 350 x 40, plus the model's working arrays).
            progress: show a tqdm progress bar.
            model_info: JSON-serialisable description of the model, stored in the metadata.
            interpolation: see the class.

        Raises:
            TypeError: ``model`` has no ``transform``, or
                ``spacing`` is not a number.
            ValueError: a bad ``spacing``, ``step`` or ``batch``, ``free`` returns a wrong shape
                or no free node, or the model cannot transform the env's panoramas (unfitted,
                fitted for another size) or returns non-finite features; the message names the
                value.
        """
        from tqdm.auto import tqdm

        import sfa_gym

        env = getattr(env, "unwrapped", env)
        if not hasattr(env, "arena_bounds") or not hasattr(env, "reset"):
            raise TypeError(f"env must be an OmniRoverEnv, got {type(env).__name__}")
        if not callable(getattr(model, "transform", None)):
            raise TypeError(
                f"model must be a fitted feature model with transform(views), got "
                f"{type(model).__name__}"
            )
        bounds = tuple(float(b) for b in env.arena_bounds)
        spacing = _check_spacing(spacing, bounds)  # type: ignore[arg-type]
        step = check_positive_int("step", step)
        batch = check_positive_int("batch", batch)
        description = _env_description(env)
        width = description["panorama_width"]
        if width is not None and width % step:
            raise ValueError(f"step {step} does not divide the panorama width {width}")
        if interpolation not in INTERPOLATIONS:
            raise ValueError(
                f"interpolation must be one of {INTERPOLATIONS}, got {interpolation!r}"
            )

        xs, ys = (
            _grid_axis(bounds[0], bounds[1], spacing),
            _grid_axis(bounds[2], bounds[3], spacing),
        )
        gx, gy = np.meshgrid(xs, ys)
        nodes = np.stack([gx.ravel(), gy.ravel()], axis=1)  # x fastest: node j * nx + i
        mask = np.ones(len(nodes), bool)
        if free is not None:
            mask = np.asarray(free(nodes.copy()))
            if mask.shape != (len(nodes),):
                raise ValueError(
                    f"free(points) must return ({len(nodes)},) bools for {len(nodes)} points, "
                    f"got shape {mask.shape}"
                )
            mask = mask.astype(bool)
            if not mask.any():
                raise ValueError(f"free(points) marks none of the {len(nodes)} grid nodes free")
        todo = np.flatnonzero(mask)

        features: NDArray[np.float64] | None = None
        render_s = feature_s = 0.0
        # the first chunk is one node, so that a wrong model fails before a batch is rendered
        starts = [0, *range(1, len(todo), batch)] if len(todo) > 1 else [0]
        with tqdm(total=len(todo), desc="feature field", unit="node", disable=not progress) as bar:
            for s, e in zip(starts, [*starts[1:], len(todo)], strict=True):
                t0 = time.perf_counter()
                panoramas = np.stack(
                    [env.reset(options={"pose": (*nodes[n], 0.0)})[0] for n in todo[s:e]]
                )
                t1 = time.perf_counter()
                f = _model_features(model, panoramas, step)
                feature_s += time.perf_counter() - t1
                render_s += t1 - t0
                if features is None:
                    features = np.zeros((len(nodes), f.shape[1]))
                elif f.shape[1] != features.shape[1]:
                    raise ValueError(
                        f"the model returned {f.shape[1]} features, before {features.shape[1]}"
                    )
                features[todo[s:e]] = f
                bar.update(e - s)
        assert features is not None  # todo is never empty
        mask2 = mask.reshape(len(ys), len(xs))
        values = fill_from_free(features.reshape(len(ys), len(xs), -1), mask2, xs, ys)
        metadata = {
            **description,
            "spacing": spacing,
            "node_spacing": [float(xs[1] - xs[0]), float(ys[1] - ys[0])],
            "step": step,
            "heading": 0.0,
            "n_features": int(values.shape[2]),
            "n_nodes": int(len(nodes)),
            "n_free": int(mask.sum()),
            "model": type(model).__name__,
            "model_info": model_info,
            "render_seconds": round(render_s, 3),
            "feature_seconds": round(feature_s, 3),
            "sfa_gym_version": sfa_gym.__version__,
            "created": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        }
        strict_json(metadata)  # refuse a model_info that cannot be saved now, not at save
        return cls(values, bounds, free=mask2, metadata=metadata, interpolation=interpolation)

    def with_interpolation(self, interpolation: str) -> FeatureField:
        """The same field with another interpolation (the values are shared)."""
        return FeatureField(
            self.values,
            self.bounds,
            free=self.free,
            metadata=self.metadata,
            interpolation=interpolation,
        )

    # -- queries -------------------------------------------------------------------------------

    def at(self, x: float, y: float) -> NDArray[np.float32]:
        """Features at one position ``(x, y)`` (m), clamped to the grid: ``(k,)`` float32.

        The fast path for one query per env step (a few microseconds).
        """
        u = (x - self._x0) * self._inv_dx
        v = (y - self._y0) * self._inv_dy
        if not (math.isfinite(u) and math.isfinite(v)):
            raise ValueError(f"position must be finite, got ({x!r}, {y!r})")
        u = 0.0 if u < 0.0 else (self._umax if u > self._umax else u)
        v = 0.0 if v < 0.0 else (self._vmax if v > self._vmax else v)
        i = min(int(u), self._cells_x - 1)
        j = min(int(v), self._cells_y - 1)
        u -= i
        v -= j
        if self._degree == 3:
            u2, v2 = u * u, v * v
            u3, v3 = u2 * u, v2 * v
            weights = [1.0, v, v2, v3, u, u * v, u * v2, u * v3,
                       u2, u2 * v, u2 * v2, u2 * v3, u3, u3 * v, u3 * v2, u3 * v3]  # fmt: skip
        else:
            weights = [1.0, v, u, u * v]
        cell = self._table[j * self._cells_x + i]
        # numpy's own loop, not BLAS, whose kernels differ per CPU (navigation.portable)
        return np.einsum("m,mk->k", np.array(weights), cell).astype(np.float32)

    def __call__(self, points: ArrayLike) -> NDArray[np.float32]:
        """Features at ``points``: ``(n, 2)`` positions (m) -> ``(n, k)`` float32; a single
        ``(2,)`` position -> ``(k,)``. Points outside the grid are clamped to it."""
        p = np.asarray(points, dtype=np.float64)
        if p.shape == (2,):
            return self.at(float(p[0]), float(p[1]))
        if p.ndim != 2 or p.shape[1] != 2:
            raise ValueError(f"points must have shape (n, 2) or (2,), got {p.shape}")
        if len(p) == 1:
            return self.at(float(p[0, 0]), float(p[0, 1]))[None]
        if not np.all(np.isfinite(p)):
            raise ValueError("points must be finite")
        u = np.clip((p[:, 0] - self._x0) * self._inv_dx, 0.0, self._umax)
        v = np.clip((p[:, 1] - self._y0) * self._inv_dy, 0.0, self._vmax)
        i = np.minimum(u.astype(np.intp), self._cells_x - 1)
        j = np.minimum(v.astype(np.intp), self._cells_y - 1)
        # powers by products: numpy's float64 power takes another kernel on AVX-512 CPUs
        pu = np.cumprod(np.column_stack([np.ones(len(p))] + [u - i] * self._degree), axis=1)
        pv = np.cumprod(np.column_stack([np.ones(len(p))] + [v - j] * self._degree), axis=1)
        weights = (pu[:, :, None] * pv[:, None, :]).reshape(len(p), (self._degree + 1) ** 2)
        cells = self._table[j * self._cells_x + i]  # (n, (d+1)^2, k)
        return np.einsum("nm,nmk->nk", weights, cells).astype(np.float32)

    def check_env(self, env: Any) -> None:
        """Raise ValueError if ``env`` renders another world or camera than the field was built
        from (world spec hash, world seed, panorama, arena bounds). A field built by hand in
        this process without this metadata passes; one read from a file must name its world
        (a file is anybody's to edit)."""
        env = getattr(env, "unwrapped", env)
        now = _env_description(env)
        missing = [key for key in WORLD_KEYS if key not in self.metadata]
        if self.from_file is not None and missing:
            raise ValueError(
                f"the feature field {str(self.from_file)!r} does not say which world it belongs "
                f"to (its metadata lacks {missing}): build it with FeatureField.build, or put "
                "the world's keys of the env in its metadata"
            )
        problems = [
            f"{key} is {now[key]!r}, the field's {self.metadata[key]!r}"
            for key in WORLD_KEYS
            if key in self.metadata and now[key] != self.metadata[key]
        ]
        bounds = tuple(float(b) for b in getattr(env, "arena_bounds", self.bounds))
        if not np.allclose(bounds, self.bounds, atol=1e-9):
            problems.append(f"arena_bounds are {bounds}, the field's {self.bounds}")
        if problems:
            raise ValueError(
                "the feature field does not belong to this env: " + "; ".join(problems)
            )

    def __repr__(self) -> str:
        ny, nx, k = self.values.shape
        return (
            f"FeatureField({nx} x {ny} nodes, spacing {self.spacing[0]:g} x {self.spacing[1]:g} "
            f"m, {k} features, {self.interpolation}, world {self.metadata.get('world')!r})"
        )

    # -- files ---------------------------------------------------------------------------------

    def header(self) -> dict[str, Any]:
        """The JSON header written by :meth:`save` (see the module docstring)."""
        return {
            "format": FORMAT,
            "version": FORMAT_VERSION,
            "shape": list(self.values.shape),
            "bounds": list(self.bounds),
            "interpolation": self.interpolation,
            "metadata": self.metadata,
        }

    def save(self, path: str | os.PathLike[str]) -> None:
        """Write the field to ``path`` (an ``.npz`` file, format in the module docstring),
        atomically.

        Raises:
            ValueError: the metadata is not JSON-serialisable (names the key of a NaN).
        """
        arrays = {
            "values": np.ascontiguousarray(self.values, dtype="<f8"),
            "free": np.ascontiguousarray(self.free),
        }
        try:
            write_npz(path, self.header(), arrays)
        except TypeError as err:
            raise ValueError(f"the field's metadata is not JSON-serialisable: {err}") from None

    @classmethod
    def load(cls, path: str | os.PathLike[str], interpolation: str | None = None) -> FeatureField:
        """Read a field written by :meth:`save`.

        Args:
            path: the ``.npz`` file.
            interpolation: override the stored interpolation (None: keep it).

        Raises:
            FileNotFoundError: no such file.
            ValueError: not a feature-field file (a pickle, another archive, another format),
                a newer format version, missing or extra members, or arrays whose dtype or
                shape do not match the header; the message names the file and what is wrong.
        """
        header, arrays = read_npz(path, "feature field", FORMAT, FORMAT_VERSION, _layout)
        try:
            field = cls(
                arrays["values"],
                header["bounds"],
                free=arrays["free"],
                metadata=header["metadata"],
                interpolation=interpolation or header["interpolation"],
            )
        except (TypeError, ValueError) as err:
            raise load_error("feature field", path, err) from None
        field.from_file = Path(path)
        return field


def _model_features(model: Any, panoramas: NDArray[np.uint8], step: int) -> NDArray[np.float64]:
    """Rotation-averaged features ``(L, k)``, with errors that say the model is the problem."""
    try:
        f = rotation_averaged_features(model, panoramas, step=step)
    except (TypeError, ValueError, AttributeError) as err:
        raise ValueError(
            f"model {type(model).__name__} cannot compute features of this env's panoramas "
            f"{panoramas.shape[1:]} (is it fitted, and for this panorama size?): {err}"
        ) from err
    if f.ndim != 2 or f.shape[0] != len(panoramas) or f.shape[1] < 1:
        raise ValueError(
            f"model {type(model).__name__} returned features of shape {f.shape} for "
            f"{len(panoramas)} panoramas, expected ({len(panoramas)}, k)"
        )
    if not np.all(np.isfinite(f)):
        raise ValueError(f"model {type(model).__name__} returned non-finite features")
    return f


def _layout(
    header: dict[str, Any], version: int
) -> tuple[dict[str, Any], dict[str, tuple[str, tuple[int, ...]]]]:
    """The header and the members it defines (see :func:`sfa_gym.files.read_npz`)."""
    missing = [k for k in ("shape", "bounds", "interpolation", "metadata") if k not in header]
    if missing:
        raise ValueError(f"the header lacks {missing}")
    shape = header["shape"]
    if not (
        isinstance(shape, list)
        and len(shape) == 3
        and all(isinstance(n, int) and not isinstance(n, bool) for n in shape)
        and shape[0] >= 2
        and shape[1] >= 2
        and shape[2] >= 1
    ):
        raise ValueError(f"the header's shape {shape!r} is not [ny >= 2, nx >= 2, k >= 1]")
    if not isinstance(header["metadata"], dict):
        kind = type(header["metadata"]).__name__
        raise ValueError(f"the header's metadata is {kind}, not a dict")
    return header, {"values": ("<f8", tuple(shape)), "free": ("|b1", tuple(shape[:2]))}
