"""The paper's outdoor localization protocol on driven runs: a training run and a test run.

:func:`run_trajectory_experiment` follows section 3.2 of Metka, Franzius & Bauer-Wersing (2013):
the rover is driven along a grid-like lawn-mower trajectory (the training run) that never enters
one corner of the arena, then along a different trajectory (the test run, by default rectangular
loops) that passes through that corner. Hierarchical SFA is fitted on every simulated rotation of
the training frames, in time order; a regression from the slow features to the ground-truth
positions is fitted on the training run and applied to the test run ("in contrast to the
simulation we compute the regression [...] for the training data and apply it to SFA outputs on
the test set"). Reported per feature method and regression:

- ``train_test``: MAE over every evaluated test frame, in metres and in % of the test run's
  coordinate range, with the standard deviation of the absolute errors;
- ``excluded`` / ``visited``: the same over the test frames inside / outside the region never
  visited in training (percentages still relative to the whole test run's range), where the
  paper notes higher errors;
- ``eta_r`` / ``eta_phi``: position and orientation variance of the features over the training
  frames and their evaluation windows.

To bound the cost, every ``frame_every``-th training frame is a training location (all its
rotations train SFA) and features for the regression are computed for ``eval_rotations`` evenly
spaced rotation windows per frame; estimates are averaged over the windows of a frame, as in
the paper.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from tqdm.auto import tqdm

from sfa_gym.experiments.common import (
    FIGURE_REGRESSOR,
    check_sfa_settings,
    fit_method,
    invariance_entry,
    mae_dict,
    methods_with_sfa,
    results_header,
)
from sfa_gym.localization import fit_predict, mae, make_regressor
from sfa_gym.localization.methods import FeatureMethod
from sfa_gym.rotation import n_rotations

__all__ = [
    "PAPER_OUTDOOR_RESULTS",
    "TrajectoryExperiment",
    "eval_windows",
    "in_rectangle",
    "run_trajectory_experiment",
    "window_features",
]

PAPER_OUTDOOR_RESULTS = {
    "mae_m": [0.23, 0.175],
    "mae_percent": [5.3, 3.7],
    "std_m": [0.20, 0.13],
    "eta_phi_min": 0.0,
    "eta_phi_max": 0.05,
}
"""The paper's outdoor figures: regression fitted on the training run, MAE (x, z) on the test
run in metres and in % of its range, standard deviations (m), range of eta_phi over outputs."""

TEST_DRIVERS = ("loop", "sweep", "random_walk")
PATTERNS = ("rows", "columns", "grid")


@dataclass(frozen=True)
class TrajectoryExperiment:
    """Settings of the trajectory protocol (defaults: the paper's outdoor experiment, scaled to
    the 6 x 6 m ``paper_sim`` arena)."""

    env_id: str = "sfa_gym/OmniRover-v0"
    """registered env to drive in and render the panoramas with"""
    world_seed: int = 0
    """seed of the world's procedural variation"""
    panorama: tuple[int, int] | None = None
    """(height, width) of the panoramas in pixels, replacing the env's camera (e.g. small
    panoramas for quick runs); None: the env's own camera"""
    spacing: float = 0.5
    """training run: distance between the lawn-mower rows, m"""
    pattern: str = "grid"
    """training run: "rows" (along x), "columns" (along y) or "grid" (rows, then columns, so that
    both axes are travelled equally, as in the paper)"""
    spin: float = 0.0
    """training run: extra rotation on the spot at each row end, rad (0: none)"""
    margin: float = 0.5
    """training run: distance kept from the arena bounds, m"""
    exclude: tuple[float, float, float, float] | None = (-3.0, -1.5, -3.0, -1.5)
    """rectangle (xmin, xmax, ymin, ymax), m, never entered by the training run (the paper's
    south-west test region); None: the training run covers the whole arena"""
    train_steps: int | None = None
    """largest number of training frames recorded (None: until the sweep is done)"""
    test_driver: str = "loop"
    """test run: "loop" (rectangular loops ``test_insets`` m from the bounds, through every
    corner), "sweep" (the lawn-mower pattern shifted by half a spacing, not excluding anything)
    or "random_walk" (needs ``test_steps``)"""
    test_insets: tuple[float, ...] = (0.5, 1.0, 1.5)
    """test run "loop": distance of each loop from the arena bounds, m"""
    test_steps: int | None = None
    """largest number of test frames recorded (None: until the test driver is done)"""
    frame_every: int = 5
    """every n-th training frame is a training location (bounds the cost of SFA)"""
    test_every: int = 1
    """every n-th test frame is evaluated"""
    step: int = 5
    """simulated rotation step, columns"""
    eval_rotations: int | None = 14
    """evenly spaced rotation windows per frame whose features the regression is fitted on and
    averages over (at most all windows); None: all windows"""
    network: str = "paper_sim"
    """SFA architecture: a preset of :mod:`sfa_gym.sfa.presets` ("paper_sim", "paper_outdoor",
    "tiny")"""
    node_dim: int = 32
    """linear SFA dimension and output dimension of every node"""
    n_outputs: int = 8
    """slow features used (the paper: 8)"""
    weight_sharing: str = "rows"
    """nodes that share weights: "rows" (one node per row of each layer's grid: rows see sky,
    horizon or ground, while along the width every position sees the same patches once all
    rotations are trained on), "layer" (one node per layer, the paper) or "none" (one per
    position; no rotation shortcut, slow)"""
    seed: int = 0
    """seed of the env resets and the drivers of both runs"""

    def validate(self) -> None:
        """Raise ValueError (or TypeError) naming the first bad setting."""
        for name in ("frame_every", "test_every", "step", "node_dim", "n_outputs"):
            _positive_int(name, getattr(self, name))
        for name in ("world_seed", "seed"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int):
                raise TypeError(f"{name} must be an int, got {value!r}")
        for name in ("train_steps", "test_steps"):
            value = getattr(self, name)
            if value is not None and (_positive_int(name, value) < 2):
                raise ValueError(f"{name} must be None or an int >= 2, got {value!r}")
        if self.eval_rotations is not None:
            _positive_int("eval_rotations", self.eval_rotations)
        if self.panorama is not None:
            if not isinstance(self.panorama, tuple | list) or len(self.panorama) != 2:
                raise ValueError(
                    f"panorama must be None or (height, width) in pixels, got {self.panorama!r}"
                )
            for value in self.panorama:
                _positive_int("panorama", value)
        for name in ("spacing", "margin"):
            value = getattr(self, name)
            if not _is_number(value) or not math.isfinite(value) or value < 0:
                raise ValueError(f"{name} must be a non-negative number of metres, got {value!r}")
        if self.spacing == 0:
            raise ValueError("spacing must be positive (metres between the lawn-mower rows)")
        if not _is_number(self.spin) or not math.isfinite(self.spin):
            raise ValueError(f"spin must be a finite angle in radians, got {self.spin!r}")
        if self.pattern not in PATTERNS:
            raise ValueError(f"pattern must be one of {PATTERNS}, got {self.pattern!r}")
        if self.exclude is not None:
            _rectangle("exclude", self.exclude)
        if self.test_driver not in TEST_DRIVERS:
            raise ValueError(f"test_driver must be one of {TEST_DRIVERS}, got {self.test_driver!r}")
        if self.test_driver == "random_walk" and self.test_steps is None:
            raise ValueError('test_driver "random_walk" never finishes: set test_steps')
        if self.test_driver == "loop":
            insets = self.test_insets
            if (
                not isinstance(insets, tuple | list)
                or not insets
                or not all(_is_number(i) and math.isfinite(i) and i >= 0 for i in insets)
            ):
                raise ValueError(
                    f"test_insets must be a non-empty tuple of distances >= 0 (m), got {insets!r}"
                )
        check_sfa_settings(self)


def _is_number(value: Any) -> bool:
    return isinstance(value, int | float | np.number) and not isinstance(value, bool)


def _positive_int(name: str, value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
        raise ValueError(f"{name} must be a positive int, got {value!r}")
    return int(value)


def _rectangle(name: str, rect: Any) -> tuple[float, float, float, float]:
    try:
        x0, x1, y0, y1 = (float(v) for v in rect)
    except (TypeError, ValueError):
        raise ValueError(
            f"{name} must be a rectangle (xmin, xmax, ymin, ymax) in metres, got {rect!r}"
        ) from None
    if not (x0 < x1 and y0 < y1) or not all(map(math.isfinite, (x0, x1, y0, y1))):
        raise ValueError(f"{name} must satisfy xmin < xmax and ymin < ymax, got {rect!r}")
    return x0, x1, y0, y1


def in_rectangle(positions: NDArray[np.float64], rect: Sequence[float] | None) -> NDArray[np.bool_]:
    """Which ``positions (N, 2)`` (m) lie strictly inside ``rect = (xmin, xmax, ymin, ymax)``;
    all False for ``rect=None``."""
    p = np.asarray(positions, dtype=np.float64)
    if rect is None:
        return np.zeros(len(p), dtype=bool)
    x0, x1, y0, y1 = rect
    return (p[:, 0] > x0) & (p[:, 0] < x1) & (p[:, 1] > y0) & (p[:, 1] < y1)


def eval_windows(width: int, step: int, count: int | None) -> NDArray[np.intp]:
    """Indices ``k`` of ``count`` evenly spaced rotation windows out of ``K = width // step``
    (all of them for ``None`` or ``count >= K``); window ``k`` is the panorama shifted by
    ``k * step`` columns."""
    n_rot = n_rotations(width, step)
    if count is None or count >= n_rot:
        return np.arange(n_rot)
    return np.unique((np.arange(count) * n_rot) // count)


def window_features(
    method: FeatureMethod,
    panoramas: NDArray[np.uint8],
    step: int,
    windows: NDArray[np.intp],
    desc: str = "features",
    progress: bool = True,
) -> NDArray[np.float64]:
    """Features ``(L, len(windows), k)`` of the rotation windows ``windows`` of each panorama
    ``(L, H, W, 3)``, a few thousand views at a time."""
    windows = np.asarray(windows, dtype=np.intp)
    per_chunk = max(1, 4096 // len(windows))
    out = []
    for i in tqdm(range(0, len(panoramas), per_chunk), desc=desc, disable=not progress):
        block = np.asarray(panoramas[i : i + per_chunk])
        views = np.stack([np.roll(block, -int(k) * step, axis=2) for k in windows], axis=1)
        features = method.transform(views.reshape(-1, *block.shape[1:]))
        out.append(np.asarray(features, dtype=np.float64).reshape(len(block), len(windows), -1))
    return np.concatenate(out)


def _drivers(config: TrajectoryExperiment) -> tuple[Any, Any]:
    from sfa_gym.recording.drivers import LawnMowerDriver, LoopDriver, RandomWalkDriver

    train = LawnMowerDriver(
        spacing=config.spacing,
        margin=config.margin,
        pattern=config.pattern,
        spin=config.spin,
        exclude=None if config.exclude is None else tuple(map(float, config.exclude)),
    )
    if config.test_driver == "loop":
        test: Any = LoopDriver(insets=tuple(map(float, config.test_insets)))
    elif config.test_driver == "sweep":
        # between the training rows and through the excluded region
        test = LawnMowerDriver(
            spacing=config.spacing,
            margin=config.margin,
            offset=config.spacing / 2,
            pattern=config.pattern,
        )
    else:
        test = RandomWalkDriver()
    return train, test


def record_runs(config: TrajectoryExperiment, out_dir: Path, progress: bool = True):
    """Record (or resume) ``train.run`` and ``test.run`` in ``out_dir``; returns both runs."""
    from sfa_gym.recording.recorder import record

    env_kwargs: dict[str, Any] = {"world_seed": config.world_seed}
    if config.panorama is not None:
        from sfa_gym.sim.camera import PanoramaSpec

        height, width = config.panorama
        env_kwargs["panorama"] = PanoramaSpec(width=int(width), height=int(height))
    train_driver, test_driver = _drivers(config)
    runs = []
    for name, driver, n_steps in (
        ("train", train_driver, config.train_steps),
        ("test", test_driver, config.test_steps),
    ):
        runs.append(
            record(
                config.env_id,
                driver,
                out_dir / f"{name}.run",
                n_steps=n_steps,
                seed=config.seed,
                env_kwargs=env_kwargs,
                progress=progress,
            )
        )
    return runs[0], runs[1]


def _run_summary(run: Any, used: NDArray[np.intp], inside: NDArray[np.bool_]) -> dict[str, Any]:
    path_m = float(np.linalg.norm(np.diff(run.poses[:, :2], axis=0), axis=1).sum())
    return {
        "path": run.path.name,
        "n_frames": len(run),
        "n_used": int(len(used)),
        "n_used_in_excluded": int(inside.sum()),
        "duration_s": float(run.time[-1] - run.time[0]),
        "distance_m": round(path_m, 3),
        "end_reason": run.metadata.get("end_reason"),
    }


def run_trajectory_experiment(
    config: TrajectoryExperiment,
    out_dir: str | os.PathLike[str],
    methods: Sequence[tuple[FeatureMethod, Sequence[str]]] = (),
    progress: bool = True,
    figures: bool = True,
) -> dict[str, Any]:
    """Run the trajectory protocol; write ``results.json``, ``sfa_model.npz`` and figures.

    Args:
        config: the protocol's settings.
        out_dir: output folder (created); the runs are kept there as ``train.run`` and
            ``test.run`` and reused (or resumed) by the next call with the same settings.
        methods: extra feature methods with the regressions to evaluate them with (names of
            :func:`~sfa_gym.localization.regression.make_regressor`). Hierarchical SFA comes
            first, with the linear regression (the paper), a quadratic one and the map decoder.
        progress: progress bars.
        figures: write the PNG figures (trajectories, estimates, error map, firing maps).

    Returns:
        The results, as written to ``results.json``.
    """
    config.validate()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    train_run, test_run = record_runs(config, out, progress)
    train_idx = np.arange(0, len(train_run), config.frame_every)
    test_idx = np.arange(0, len(test_run), config.test_every)
    if len(train_idx) < 2 or len(test_idx) < 2:
        raise ValueError(
            f"need at least 2 training locations and 2 test frames, got {len(train_idx)} and "
            f"{len(test_idx)}: lower frame_every/test_every or record longer runs"
        )
    train_pan = np.asarray(train_run.panoramas[train_idx])
    test_pan = np.asarray(test_run.panoramas[test_idx])
    train_xy, test_xy = train_run.positions[train_idx], test_run.positions[test_idx]
    width = train_pan.shape[2]
    windows = eval_windows(width, config.step, config.eval_rotations)
    train_inside = in_rectangle(train_xy, config.exclude)
    test_inside = in_rectangle(test_xy, config.exclude)
    test_range = test_xy.max(axis=0) - test_xy.min(axis=0)

    sfa, entries = methods_with_sfa(config, methods, progress)
    results: dict[str, Any] = {
        **results_header("trajectory", config, width),
        "eval_windows": windows.tolist(),
        "runs": {
            "train": _run_summary(train_run, train_idx, train_inside),
            "test": _run_summary(test_run, test_idx, test_inside),
        },
        "paper": PAPER_OUTDOOR_RESULTS,
        "methods": {},
    }
    sfa_outputs: dict[str, Any] = {}
    for method, regressors in entries:
        fitted = fit_method(method, train_pan, config.step)
        f_train = window_features(
            fitted, train_pan, config.step, windows, f"{method.name} train", progress
        )
        f_test = window_features(
            fitted, test_pan, config.step, windows, f"{method.name} test", progress
        )
        entry = invariance_entry(f_train)
        for name in dict.fromkeys(regressors):
            estimates = fit_predict(make_regressor(name), f_train, train_xy, f_test)
            entry[name] = {"train_test": mae_dict(mae(estimates, test_xy))}
            for part, where in (("excluded", test_inside), ("visited", ~test_inside)):
                entry[name][part] = (
                    mae_dict(mae(estimates[where], test_xy[where], coordinate_range=test_range))
                    if where.any()
                    else None
                )
            if method is sfa and name == FIGURE_REGRESSOR:
                sfa_outputs["estimates"] = estimates
        results["methods"][method.name] = entry
        if method is sfa:
            sfa_outputs["model"] = fitted.model_
    model = sfa_outputs["model"]
    model.save(out / "sfa_model.npz")
    text = json.dumps(results, indent=2)
    (out / "results.json").write_text(text + "\n")
    # what is returned is what was written (tuples of the config become lists)
    results = json.loads(text)
    if figures:
        _figures(
            out,
            config,
            model,
            train_run,
            test_run,
            train_pan,
            train_xy,
            test_xy,
            test_run.time[test_idx],
            sfa_outputs["estimates"],
        )
    return results


def _exclude_patch(rect: Sequence[float]):
    from matplotlib.patches import Rectangle

    x0, x1, y0, y1 = rect
    return Rectangle(
        (x0, y0),
        x1 - x0,
        y1 - y0,
        facecolor="tab:red",
        alpha=0.15,
        edgecolor="tab:red",
        hatch="//",
        label="not visited in training",
    )


def _figures(
    out: Path,
    config: TrajectoryExperiment,
    model: Any,
    train_run: Any,
    test_run: Any,
    train_pan: NDArray[np.uint8],
    train_xy: NDArray[np.float64],
    test_xy: NDArray[np.float64],
    test_time: NDArray[np.float64],
    estimates: NDArray[np.float64],
) -> None:
    from matplotlib.figure import Figure

    from sfa_gym.localization import plots

    bounds = train_run.metadata.get("arena_bounds")
    bounds = tuple(bounds) if bounds else None

    fig = Figure(figsize=(10.0, 5.0), layout="constrained")
    axes = fig.subplots(1, 2)
    for ax, run, title in ((axes[0], train_run, "training run"), (axes[1], test_run, "test run")):
        plots.trajectory(run.poses, bounds=bounds, fig=fig, ax=ax)
        if config.exclude is not None:
            ax.add_patch(_exclude_patch(config.exclude))
            ax.legend(loc="upper right", fontsize=8)
        ax.set_title(f"{title}: {len(run)} frames")
    fig.savefig(out / "trajectories.png", dpi=110)

    fig = Figure(figsize=(11.0, 5.0), layout="constrained")
    grid = fig.add_gridspec(2, 2, width_ratios=(1.0, 1.3))
    ax = fig.add_subplot(grid[:, 0])
    if config.exclude is not None:
        ax.add_patch(_exclude_patch(config.exclude))
    ax.plot(test_xy[:, 0], test_xy[:, 1], color="black", lw=1.0, label="ground truth")
    ax.plot(estimates[:, 0], estimates[:, 1], ".", color="tab:blue", ms=2.5, label="estimate")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(f"test run, SFA + {FIGURE_REGRESSOR} regression")
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=3, fontsize=8)
    inside = in_rectangle(test_xy, config.exclude)
    for row, axis in enumerate("xy"):
        a = fig.add_subplot(grid[row, 1])
        a.plot(test_time, test_xy[:, row], color="black", lw=1.0, label="ground truth")
        a.plot(test_time, estimates[:, row], color="tab:blue", lw=0.8, label="estimate")
        if inside.any():
            a.fill_between(
                test_time,
                0,
                1,
                where=inside,
                color="tab:red",
                alpha=0.15,
                transform=a.get_xaxis_transform(),
                label="in the region not visited in training",
            )
        a.set_ylabel(f"{axis} (m)")
        if row == 1:
            a.set_xlabel("time (s)")
        else:
            a.legend(loc="upper right", fontsize=7)
    fig.savefig(out / "estimates.png", dpi=110)

    fig, ax = plots.error_map(estimates, test_xy)
    if config.exclude is not None:
        patch = _exclude_patch(config.exclude)
        patch.set_facecolor("none")
        ax.add_patch(patch)
    ax.set_title(f"test run: absolute error, SFA + {FIGURE_REGRESSOR} regression")
    fig.savefig(out / "error_map.png", dpi=110)

    # firing maps over the training locations at the views nearest 0, 90, 180 and 270 degrees
    width = train_pan.shape[2]
    n_rot = n_rotations(width, config.step)
    ks = sorted({round(q * n_rot / 4) % n_rot for q in range(4)})
    phis = np.array([2 * np.pi * k * config.step / width for k in ks])
    outputs = np.stack(
        [model.transform(np.roll(train_pan, -k * config.step, axis=2)) for k in ks], axis=1
    )
    fig, axes = plots.firing_maps(outputs, train_xy, phis=phis, n_outputs=min(4, outputs.shape[2]))
    if bounds is not None:
        for a in axes.flat:
            a.set_xlim(bounds[0], bounds[1])
            a.set_ylim(bounds[2], bounds[3])
    fig.savefig(out / "firing_maps.png", dpi=110)
