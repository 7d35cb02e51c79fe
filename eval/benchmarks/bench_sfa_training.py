"""Timing and memory of hierarchical SFA training at paper scale, on synthetic panoramas.

The panoramas are smooth random images (periodic in width) that morph slowly from one location
to the next along a path, so that consecutive training locations look alike as on a real run.
Backs docs/speed.md. Use it to check that a preset trains within budget on a given machine
(from the repository root)::

    # fit_rotations
    .venv/bin/python -m eval.benchmarks.bench_sfa_training --preset paper_outdoor --locations 5900
    # fit on frames
    .venv/bin/python -m eval.benchmarks.bench_sfa_training --preset paper_sim --views 2000

The numbers depend on the machine and its load; BLAS threads follow ``OPENBLAS_NUM_THREADS``.
"""

from __future__ import annotations

import json
import resource
import time
import warnings
from dataclasses import dataclass
from typing import Any, Literal

import tyro

from eval.synthetic import synthetic_panoramas
from sfa_gym.rotation import rotated_views
from sfa_gym.sfa import HierarchicalSFA, RankDeficiencyWarning, presets

__all__ = ["benchmark_rotation_training", "benchmark_view_training"]

PRESET_SHAPES = {"paper_sim": (40, 350), "paper_outdoor": (60, 600)}


def benchmark_rotation_training(
    preset: str = "paper_outdoor",
    n_locations: int = 5900,
    step: int = 5,
    seed: int = 0,
    dtype: str = "float32",
    n_transform: int = 200,
    progress: bool = True,
    weight_sharing: str = "layer",
) -> dict[str, Any]:
    """Train ``preset`` with :meth:`HierarchicalSFA.fit_rotations` on synthetic panoramas
    (``weight_sharing`` as for :class:`HierarchicalSFA`).

    Returns:
        dict with ``fit_seconds`` (wall), ``fit_cpu_seconds`` (this process, all threads),
        ``peak_rss_mb`` (process peak, including the panoramas themselves, ``panoramas_mb``),
        ``transform_ms_per_view``, ``n_views``, ``fit_method`` and the setting.
    """
    if preset not in PRESET_SHAPES:
        raise ValueError(f"preset must be one of {sorted(PRESET_SHAPES)}, got {preset!r}")
    height, width = PRESET_SHAPES[preset]
    layers = getattr(presets, preset)()
    pans = synthetic_panoramas(n_locations, height, width, seed)
    model = HierarchicalSFA(layers, weight_sharing=weight_sharing, dtype=dtype, progress=progress)
    t0, c0 = time.perf_counter(), time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RankDeficiencyWarning)
        model.fit_rotations(pans, step=step)
    fit_s, fit_cpu = time.perf_counter() - t0, time.process_time() - c0
    views = rotated_views(pans[: max(1, n_transform)], step, indices=[1])[0][:, 0]
    model.transform(views[:2])
    t0 = time.perf_counter()
    model.transform(views)
    per_view = (time.perf_counter() - t0) / len(views) * 1e3
    return {
        "preset": preset,
        "n_locations": n_locations,
        "n_views": int(model.n_training_views_),
        "step": step,
        "weight_sharing": weight_sharing,
        "dtype": dtype,
        "fit_method": model.fit_method_,
        "fit_seconds": round(fit_s, 2),
        "fit_cpu_seconds": round(fit_cpu, 2),
        "peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1),
        "panoramas_mb": round(pans.nbytes / 2**20, 1),
        "transform_ms_per_view": round(per_view, 3),
        "delta_values": [round(float(d), 6) for d in model.delta_values_],
    }


def benchmark_view_training(
    preset: str = "paper_sim",
    n_views: int = 2000,
    seed: int = 0,
    dtype: str = "float32",
    progress: bool = True,
) -> dict[str, Any]:
    """Train ``preset`` with :meth:`HierarchicalSFA.fit` on ``n_views`` frames of a path.

    No rotation structure to exploit: every frame is a new image (the generic path). Returns
    the same kind of dict as :func:`benchmark_rotation_training`, plus ``ms_per_view``.
    """
    if preset not in PRESET_SHAPES:
        raise ValueError(f"preset must be one of {sorted(PRESET_SHAPES)}, got {preset!r}")
    height, width = PRESET_SHAPES[preset]
    views = synthetic_panoramas(n_views, height, width, seed)
    model = HierarchicalSFA(getattr(presets, preset)(), dtype=dtype, progress=progress)
    t0, c0 = time.perf_counter(), time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RankDeficiencyWarning)
        model.fit(views)
    fit_s, fit_cpu = time.perf_counter() - t0, time.process_time() - c0
    return {
        "preset": preset,
        "n_views": n_views,
        "dtype": dtype,
        "fit_method": model.fit_method_,
        "fit_seconds": round(fit_s, 2),
        "fit_cpu_seconds": round(fit_cpu, 2),
        "ms_per_view": round(fit_s / n_views * 1e3, 2),
        "peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1),
    }


@dataclass(frozen=True)
class Args:
    preset: Literal["paper_outdoor", "paper_sim"] = "paper_outdoor"
    """network preset (and its panorama size, PRESET_SHAPES)"""
    locations: int = 5900
    """training locations of the rotation training"""
    views: int = 0
    """train on this many path frames instead (fit); 0: rotation training"""
    step: int = 5
    """rotation step, columns"""
    rows: bool = False
    """one node per grid row (rotation training only)"""
    dtype: Literal["float32", "float64"] = "float32"
    """the network's float type"""
    seed: int = 0
    """seed of the synthetic panoramas"""
    progress: bool = True
    """progress bars (--no-progress: none)"""


def main(argv: list[str] | None = None) -> None:
    """Command line: print the benchmark result as JSON."""
    args = tyro.cli(Args, args=argv, description=__doc__.splitlines()[0])
    if args.views:
        result = benchmark_view_training(
            args.preset, args.views, args.seed, args.dtype, progress=args.progress
        )
    else:
        result = benchmark_rotation_training(
            args.preset, args.locations, args.step, args.seed, args.dtype,
            progress=args.progress, weight_sharing="rows" if args.rows else "layer",
        )  # fmt: skip
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
