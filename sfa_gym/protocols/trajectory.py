"""The trajectory protocol: the paper's outdoor protocol (section 3.2) on driven runs.

The rover is driven along a grid-like lawn-mower trajectory (the training run) that never enters
one corner of the arena, then along a different trajectory (the test run, by default
rectangular loops) that passes through that corner. The feature method is fitted on every
simulated rotation of the training locations (every ``frame_every``-th training frame) in time
order; a regression from the features of ``eval_rotations`` evenly spaced rotation windows to
the ground-truth positions is fitted on the training run and applied to the test run ("in
contrast to the simulation we compute the regression [...] for the training data and apply it
to SFA outputs on the test set"); the estimate of a frame is the mean over its windows. Scored
per regression:

- ``train_test``: MAE over every evaluated test frame, in metres and in % of the test run's
  coordinate range, with the standard deviation of the absolute errors;
- ``excluded`` / ``visited``: the same over the test frames inside / outside the region never
  visited in training (percentages still relative to the whole test run's range), where the
  paper notes higher errors.

The leaderboard's ``unvisited_region`` track and ``sfa-gym localize-run`` are this protocol.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from sfa_gym._checks import check_finite, check_int, check_positive_int, check_world_seed
from sfa_gym.features import fitted_features, invariance_entry, method_regressors
from sfa_gym.geometry import check_rectangle, in_rectangle
from sfa_gym.localization import fit_predict, mae, make_regressor
from sfa_gym.localization.metrics import MAE, mae_dict
from sfa_gym.phases import phase
from sfa_gym.plugins import FeatureMethod
from sfa_gym.protocols import RunSource
from sfa_gym.protocols.scores import MethodScores
from sfa_gym.protocols.settings import RenderSettings, check_choice
from sfa_gym.recording.cache import RunRequest
from sfa_gym.rotation import spread_indices

__all__ = [
    "Config",
    "RegressionScores",
    "Scores",
    "TrajectoryData",
    "drivers",
    "load",
    "requests",
    "score",
]

TestDriver = Literal["loop", "sweep", "random_walk"]
Pattern = Literal["rows", "columns", "grid"]


@dataclass(frozen=True)
class Config(RenderSettings):
    """Settings of the trajectory protocol (defaults: the paper's outdoor experiment, scaled to
    the 6 x 6 m ``paper_sim`` arena)."""

    spacing: float = 0.5
    """training run: distance between the lawn-mower rows, m"""
    pattern: Pattern = "grid"
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
    test_driver: TestDriver = "loop"
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
    eval_rotations: int | None = 14
    """evenly spaced rotation windows per frame whose features the regression is fitted on and
    averages over (at most all windows); None: all windows"""
    seed: int = 0
    """seed of the env resets and the drivers of both runs"""

    def validate(self) -> None:
        """Raise ValueError (or TypeError) naming the first bad setting."""
        self.validate_rendering()
        for name in ("frame_every", "test_every"):
            check_positive_int(name, getattr(self, name))
        check_int("seed", self.seed)
        for name in ("train_steps", "test_steps"):
            value = getattr(self, name)
            if value is not None and (check_positive_int(name, value) < 2):
                raise ValueError(f"{name} must be None or an int >= 2, got {value!r}")
        check_positive_int("eval_rotations", self.eval_rotations, none=True)
        for name in ("spacing", "margin"):
            check_finite(name, getattr(self, name), low=0.0)
        if self.spacing == 0:
            raise ValueError("spacing must be positive (metres between the lawn-mower rows)")
        check_finite("spin", self.spin)
        check_choice("pattern", self.pattern, Pattern)
        if self.exclude is not None:
            check_rectangle("exclude", self.exclude)
        check_choice("test_driver", self.test_driver, TestDriver)
        if self.test_driver == "random_walk" and self.test_steps is None:
            raise ValueError('test_driver "random_walk" never finishes: set test_steps')
        if self.test_driver == "loop":
            insets = self.test_insets
            if not isinstance(insets, tuple | list) or not insets:
                raise ValueError(
                    f"test_insets must be a non-empty tuple of distances >= 0 (m), got {insets!r}"
                )
            for inset in insets:
                check_finite("test_insets", inset, low=0.0)


def drivers(config: Config) -> tuple[Any, Any]:
    """The drivers of the training run and of the test run that ``config`` describes.

    Returns:
        ``(train, test)``: a :class:`~sfa_gym.recording.drivers.LawnMowerDriver` (never entering
        ``config.exclude``) and the test driver named by ``config.test_driver``.
    """
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


def requests(config: Config, world_seed: int) -> dict[str, RunRequest]:
    """The two runs of the protocol: ``{"train": request, "test": request}``."""
    panorama = None if config.panorama is None else tuple(config.panorama)
    train, test = drivers(config)
    return {
        name: RunRequest(
            world=config.world,
            world_seed=world_seed,
            panorama=panorama,
            driver=driver,
            n_steps=n_steps,
            seed=config.seed,
            env_id=config.env_id,
        )
        for name, driver, n_steps in (
            ("train", train, config.train_steps),
            ("test", test, config.test_steps),
        )
    }


@dataclass
class TrajectoryData:
    """The two runs of one world and what the protocol uses of them.

    Attributes:
        train_idx, test_idx: the training locations and the evaluated test frames.
        train_pan, test_pan: their panoramas ``(L, H, W, 3)``, ``(M, H, W, 3)``.
        train_xy, test_xy: their positions ``(L, 2)``, ``(M, 2)``.
        windows: the evaluated rotation windows.
        train_inside, test_inside: whether each is inside ``config.exclude``.
        test_range: the test frames' coordinate range ``(2,)`` (m), the base of every %.
    """

    train_run: Any
    test_run: Any
    train_idx: NDArray[np.intp]
    test_idx: NDArray[np.intp]
    train_pan: NDArray[np.uint8]
    test_pan: NDArray[np.uint8]
    train_xy: NDArray[np.float64]
    test_xy: NDArray[np.float64]
    windows: NDArray[np.intp]
    train_inside: NDArray[np.bool_]
    test_inside: NDArray[np.bool_]
    test_range: NDArray[np.float64]


def load(config: Config, world_seed: int, runs: RunSource) -> TrajectoryData:
    """The runs of ``world_seed`` from ``runs`` (rendered there if needed), subsampled as the
    protocol says.

    Raises:
        ValueError: fewer than 2 training locations or 2 evaluated test frames.
    """
    found = requests(config, world_seed)
    with phase("render"):
        train_run, test_run = runs.get(found["train"]), runs.get(found["test"])
    train_idx = np.arange(0, len(train_run), config.frame_every)
    test_idx = np.arange(0, len(test_run), config.test_every)
    if len(train_idx) < 2 or len(test_idx) < 2:
        raise ValueError(
            f"need at least 2 training locations and 2 test frames, got {len(train_idx)} and "
            f"{len(test_idx)}: lower frame_every/test_every or record longer runs"
        )
    train_pan = np.asarray(train_run.panoramas[train_idx])
    train_xy, test_xy = train_run.positions[train_idx], test_run.positions[test_idx]
    windows = spread_indices(config.rotation.n_views(train_pan.shape[2]), config.eval_rotations)
    return TrajectoryData(
        train_run=train_run,
        test_run=test_run,
        train_idx=train_idx,
        test_idx=test_idx,
        train_pan=train_pan,
        test_pan=np.asarray(test_run.panoramas[test_idx]),
        train_xy=train_xy,
        test_xy=test_xy,
        windows=windows,
        train_inside=in_rectangle(train_xy, config.exclude),
        test_inside=in_rectangle(test_xy, config.exclude),
        test_range=test_xy.max(axis=0) - test_xy.min(axis=0),
    )


@dataclass
class RegressionScores:
    """One regression's scores on the test run.

    Attributes:
        estimates: the evaluated test frames' estimates ``(M, 2)`` (m).
        train_test: MAE over every evaluated test frame.
        excluded, visited: MAE over the test frames inside / outside ``config.exclude`` (None
            when there are none), in % of the whole test run's range.
    """

    estimates: NDArray[np.float64]
    train_test: MAE
    excluded: MAE | None
    visited: MAE | None

    def entry(self) -> dict[str, Any]:
        """The scores as ``results.json`` holds them (rounded MAE entries)."""
        return {
            "train_test": mae_dict(self.train_test),
            "excluded": None if self.excluded is None else mae_dict(self.excluded),
            "visited": None if self.visited is None else mae_dict(self.visited),
        }


@dataclass
class Scores(MethodScores):
    """What :func:`score` found for one method (see :class:`~sfa_gym.protocols.scores.
    MethodScores`); ``data`` is the :class:`TrajectoryData` it was scored on."""

    config: Config
    data: TrajectoryData

    def task_scores(self) -> dict[str, Any]:
        """A leaderboard task's scores (JSON types), with the first regression: ``score`` is the
        mean over x and y of the MAE in % of the test run's range over the test frames in the
        region never visited in training (``mae_percent`` per axis); ``all_test_frames`` the
        same over every evaluated test frame.

        Raises:
            ValueError: no evaluated test frame lies in that region.
        """
        name, found = self.first()
        if found.excluded is None:
            raise ValueError(
                f"no evaluated test frame lies in the region never visited in training "
                f"(exclude={self.config.exclude!r}); a task scores on those"
            )
        data = self.data
        return {
            "regressor": name,
            "n_features": self.invariance["n_features"],
            "score": float(np.mean(found.excluded.mae_percent)),
            "mae_percent": found.excluded.mae_percent.tolist(),
            "all_test_frames": float(np.mean(found.train_test.mae_percent)),
            "frames": {
                "train": len(data.train_idx),
                "test": len(data.test_idx),
                "in_region": int(data.test_inside.sum()),
            },
        }


def score(
    config: Config,
    method: FeatureMethod,
    world_seed: int,
    runs: RunSource,
    *,
    regressors: Sequence[str] | None = None,
    progress: bool = False,
) -> Scores:
    """Fit ``method`` on the training run of ``world_seed`` and score it on the test run; writes
    no files.

    Args:
        config: the protocol's settings (checked first).
        method: an unfitted feature method.
        world_seed: the world driven in.
        runs: where the rendered runs come from.
        regressors: names of :func:`~sfa_gym.localization.regression.make_regressor` to score
            (repeats count once); None: the method's ``regressor`` (default linear).
        progress: progress bars.
    """
    config.validate()
    check_world_seed("world_seed", world_seed)
    names = method_regressors(method, regressors)
    data = load(config, world_seed, runs)
    fitted, f_train, f_test = fitted_features(
        method, data.train_pan, config.rotation, data.train_pan, data.test_pan, data.windows,
        progress,
    )  # fmt: skip
    regressions = {}
    for name in names:
        estimates = fit_predict(make_regressor(name), f_train, data.train_xy, f_test)
        parts = {}
        for part, where in (("excluded", data.test_inside), ("visited", ~data.test_inside)):
            parts[part] = (
                mae(estimates[where], data.test_xy[where], coordinate_range=data.test_range)
                if where.any()
                else None
            )
        regressions[name] = RegressionScores(
            estimates, mae(estimates, data.test_xy, coordinate_range=data.test_range), **parts
        )
    return Scores(config, fitted, invariance_entry(f_train), regressions, data)
