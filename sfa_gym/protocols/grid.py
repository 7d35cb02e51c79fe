"""The grid protocol: the paper's simulator localization protocol, on a grid of positions.

The rover is placed on a regular grid of positions with random headings (one render of all
positions, in visiting order); a training subset of the positions, visited along a
space-filling curve, and a disjoint test subset are selected. The feature method is fitted on
every simulated rotation of the training panoramas (all views of one location, then the next);
per regression, the evaluations of :attr:`Config.evaluations` are scored, estimates averaged over
the rotated views of a location, as in the paper:

- ``train_test``: regression fitted on the training positions, applied to the test positions;
- ``paper_splits``: the paper's protocol: regression fitted and scored on ``n_splits`` random
  50/50 splits of the test positions (MAE in % of the test set's coordinate range);
- ``few_labels``: as ``train_test``, with the regression seeing only ``labels`` randomly drawn
  training positions (each count its own draw, the same for every method).

The leaderboard's tracks ``paper_sim_parity``, ``train_test``, ``few_labels`` and
``unseen_worlds`` (the method fitted on another world: ``fit_world_seed`` of :func:`score`) and
``sfa-gym localize`` are this protocol.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from sfa_gym._checks import check_fits_in_memory, check_int, check_positive_int, check_world_seed
from sfa_gym.features import fitted_features, invariance_entry, method_regressors
from sfa_gym.localization import fit_predict, mae, make_regressor, random_split_mae
from sfa_gym.localization.metrics import MAE, SplitMAE, mae_dict
from sfa_gym.phases import phase
from sfa_gym.plugins import FeatureMethod
from sfa_gym.protocols import RunSource
from sfa_gym.protocols.scores import MethodScores
from sfa_gym.protocols.settings import RenderSettings, check_choice, check_choices
from sfa_gym.recording.cache import RunRequest

__all__ = [
    "Config",
    "GridData",
    "RegressionScores",
    "Scores",
    "load",
    "requests",
    "score",
    "scored_together",
    "select_positions",
    "training_panoramas",
    "training_sequence",
]

GridOrder = Literal["hilbert", "serpentine", "raster", "sweeps"]
GridEvaluation = Literal["train_test", "paper_splits", "few_labels"]


@dataclass(frozen=True)
class Config(RenderSettings):
    """Settings of the grid protocol (defaults: the paper's simulator experiment)."""

    grid: int = 30
    """positions per side of the square grid over the arena"""
    n_train: int = 624
    """training positions (visited in ``order``)"""
    n_test: int = 196
    """test positions, disjoint from the training positions"""
    order: GridOrder = "hilbert"
    """order of the training positions: "hilbert", "serpentine", "raster", or "sweeps" (a
    serpentine along the rows, then one along the columns: every training position twice, as
    the outdoor drive's two sweeps; the grid is rendered in serpentine order)"""
    evaluations: tuple[GridEvaluation, ...] = ("train_test", "paper_splits")
    """evaluations scored per regression, in this order: "train_test" (fitted on the training
    positions), "paper_splits" (the paper's random splits of the test positions), "few_labels"
    (fitted on ``labels`` training positions); the first is a leaderboard task's score"""
    n_splits: int = 100
    """random 50/50 splits of the test positions (the paper: 100)"""
    labels: tuple[int, ...] = (12, 25, 50)
    """few_labels: the numbers of labelled training positions the regression sees"""
    seed: int = 0
    """seed of the headings, the train/test selection and the splits"""
    free_cells: bool = False
    """leave out the grid's cells where the rover does not fit (worlds with obstacles, walls or
    building blocks, such as the campus); the training and test positions are drawn from the
    others"""

    def validate(self) -> None:
        """Raise ValueError (or TypeError) naming the first bad setting."""
        self.validate_rendering()
        check_int("seed", self.seed)
        if not isinstance(self.free_cells, bool):
            raise TypeError(f"free_cells must be True or False, got {self.free_cells!r}")
        for name in ("grid", "n_train", "n_test", "n_splits"):
            check_positive_int(name, getattr(self, name))
        check_choice("order", self.order, GridOrder)
        check_choices("evaluations", self.evaluations, GridEvaluation, "an evaluation")
        # the whole grid is rendered and held (a panorama and a pose per position)
        check_fits_in_memory(
            f"grid {self.grid} ({self.grid**2} positions)",
            self.grid**2 * (self.panorama_bytes() + 3 * 8),
        )
        if self.n_train + self.n_test > self.grid**2:
            raise ValueError(
                f"n_train + n_test = {self.n_train + self.n_test} positions do not fit on a "
                f"{self.grid} x {self.grid} grid ({self.grid**2} positions)"
            )
        if self.n_train < 2 or self.n_test < 4:
            raise ValueError(
                f"need n_train >= 2 and n_test >= 4, got {self.n_train} and {self.n_test}"
            )
        if "few_labels" in self.evaluations:
            self._check_labels()

    def _check_labels(self) -> None:
        if not isinstance(self.labels, tuple | list) or not self.labels:
            raise ValueError(f"labels must be a non-empty tuple of ints, got {self.labels!r}")
        for n_labels in self.labels:
            if check_positive_int("labels", n_labels) > self.n_train:
                raise ValueError(
                    f"labels {n_labels} exceeds the {self.n_train} training positions (n_train)"
                )


def _positions(config: Config) -> Any:
    """The grid's poses: every cell's, or with ``free_cells`` those where the rover fits."""
    from sfa_gym.recording.drivers import GridPositions
    from sfa_gym.recording.poses import FreeGridPositions

    kind = FreeGridPositions if config.free_cells else GridPositions
    order = "serpentine" if config.order == "sweeps" else config.order
    return kind(n=config.grid, seed=config.seed, order=order)


def requests(config: Config, world_seed: int) -> dict[str, RunRequest]:
    """The one run of the protocol: ``{"grid": request}``, every grid position (with
    ``free_cells``: every one where the rover fits)."""
    driver = _positions(config)
    request = RunRequest(
        world=config.world,
        world_seed=world_seed,
        panorama=None if config.panorama is None else tuple(config.panorama),
        driver=driver,
        seed=config.seed,
        env_id=config.env_id,
    )
    return {"grid": request}


def select_positions(config: Config, n_positions: int) -> tuple[NDArray, NDArray]:
    """Indices (into the visiting order) of the training and test positions.

    Training positions keep the visiting order, so their sequence follows the curve.

    Raises:
        ValueError: fewer than ``n_train + n_test`` positions (the free cells of a world with
            obstacles or blocks).
    """
    if config.n_train + config.n_test > n_positions:
        raise ValueError(
            f"n_train + n_test = {config.n_train + config.n_test} positions, but the grid has "
            f"only {n_positions} where the rover fits: lower them or raise grid"
        )
    rng = np.random.default_rng(config.seed)
    chosen = rng.permutation(n_positions)
    train = np.sort(chosen[: config.n_train])
    test = np.sort(chosen[config.n_train : config.n_train + config.n_test])
    return train, test


def training_sequence(
    config: Config, train: NDArray[np.intp], positions: NDArray[np.float64]
) -> NDArray[np.intp]:
    """The indices (into the visiting order) of the panoramas the method is fitted on, in
    training order: the training positions ``train`` in visiting order; with ``order="sweeps"``
    followed by the same positions in a serpentine along the columns (x slow, y back and
    forth), so that each coordinate is the slow one in one sweep. ``positions (L, 2)``: every
    position's x, y in visiting order."""
    if config.order != "sweeps":
        return train
    x, y = positions[train, 0], positions[train, 1]
    column = np.unique(np.round(x, 6), return_inverse=True)[1]
    along = np.where(column % 2 == 0, y, -y)  # up one column, down the next
    return np.concatenate([train, train[np.lexsort((along, column))]])


def training_panoramas(env: Any, config: Config, progress: bool = True) -> NDArray[np.uint8]:
    """The panoramas ``(n_train, H, W, 3)`` of ``config``'s training positions in visiting
    order, each rendered in memory by ``env.reset(options={"pose": pose})``: for scripts that
    train the protocol's network on an env they set up themselves (another camera, say) and
    need no run file. A network fitted on them with ``fit_rotations(panoramas, step=config.step)``
    is the one the protocol trains on the same world.

    Args:
        env: an OmniRoverEnv (or a wrapper of one) whose observation is the panorama.
        config: the protocol's settings (grid, n_train, n_test, order, seed are read).
        progress: show a progress bar.
    """
    from tqdm.auto import tqdm

    config.validate()
    poses = _positions(config).poses(env)
    train, _ = select_positions(config, len(poses))
    sequence = training_sequence(config, train, np.asarray(poses)[:, :2])
    return np.stack(
        [
            env.reset(options={"pose": tuple(float(v) for v in poses[i])})[0]
            for i in tqdm(sequence, desc="training grid", disable=not progress)
        ]
    )


@dataclass
class GridData:
    """The rendered grid of one world: ``panoramas (L, H, W, 3)`` and ``positions (L, 2)`` of
    every position in visiting order, the ``train`` and ``test`` indices into them."""

    panoramas: NDArray[np.uint8]
    positions: NDArray[np.float64]
    train: NDArray[np.intp]
    test: NDArray[np.intp]


def load(config: Config, world_seed: int, runs: RunSource) -> GridData:
    """The grid of ``world_seed`` from ``runs`` (rendered there if needed), with the training
    and test positions the protocol selects."""
    with phase("render"):
        run = runs.get(requests(config, world_seed)["grid"])
    train, test = select_positions(config, len(run))
    return GridData(np.asarray(run.panoramas), run.positions, train, test)


@dataclass
class RegressionScores:
    """One regression's evaluations (those of :attr:`Config.evaluations`; the others None).

    Attributes:
        estimates: ``train_test``: the test positions' estimates ``(M, 2)`` (m).
        few_labels: per number of labels, the MAE on the test positions.
    """

    train_test: MAE | None = None
    estimates: NDArray[np.float64] | None = None
    paper_splits: SplitMAE | None = None
    few_labels: dict[int, MAE] = field(default_factory=dict)

    def entry(self) -> dict[str, Any]:
        """The evaluations as ``results.json`` holds them (rounded MAE entries)."""
        out: dict[str, Any] = {}
        if self.train_test is not None:
            out["train_test"] = mae_dict(self.train_test)
        if self.paper_splits is not None:
            out["paper_splits"] = mae_dict(self.paper_splits)
        if self.few_labels:
            out["few_labels"] = {str(n): mae_dict(m) for n, m in self.few_labels.items()}
        return out


@dataclass
class Scores(MethodScores):
    """What :func:`score` found for one method (see :class:`~sfa_gym.protocols.scores.
    MethodScores`); ``data`` is the :class:`GridData` it was scored on."""

    config: Config
    data: GridData

    def task_scores(self, evaluation: str | None = None) -> dict[str, Any]:
        """A leaderboard task's scores (JSON types): with the first regression, ``score`` is
        the mean over x and y of the MAE in % of ``evaluation`` (default: the config's first),
        with its parts (``mae_percent``, or ``labels_<n>`` per number of labels)."""
        name, found = self.first()
        out: dict[str, Any] = {"regressor": name, "n_features": self.invariance["n_features"]}
        evaluation = evaluation or self.config.evaluations[0]
        if evaluation not in self.config.evaluations:
            scored = list(self.config.evaluations)
            raise ValueError(f"evaluation {evaluation!r} was not scored (scored: {scored})")
        if evaluation == "few_labels":
            per_count = [_mean_percent(m) for m in found.few_labels.values()]
            for n_labels, value in zip(found.few_labels, per_count, strict=True):
                out[f"labels_{n_labels}"] = value
            out["score"] = float(np.mean(per_count))
            return out
        result = found.train_test if evaluation == "train_test" else found.paper_splits
        out["score"] = _mean_percent(result)
        out["mae_percent"] = result.mae_percent.tolist()
        return out


def scored_together(config: Config, other: Config) -> bool:
    """Whether one run can score ``other``'s evaluations beside ``config``'s: the settings are
    the same but for ``evaluations``. The fit, the features and each evaluation (seeded on its
    own) do not depend on which other evaluations are scored, so a task of the paper's splits,
    one of training -> test and one of few labels on the same world fit the method once."""
    return replace(config, evaluations=other.evaluations) == other


def _mean_percent(result: Any) -> float:
    return float(np.mean(result.mae_percent))


def score(
    config: Config,
    method: FeatureMethod,
    world_seed: int,
    runs: RunSource,
    *,
    regressors: Sequence[str] | None = None,
    fit_world_seed: int | None = None,
    progress: bool = False,
) -> Scores:
    """Fit ``method`` and score it on the grid of ``world_seed``; writes no files.

    Args:
        config: the protocol's settings (checked first).
        method: an unfitted feature method.
        world_seed: the world scored on.
        runs: where the rendered grid comes from.
        regressors: names of :func:`~sfa_gym.localization.regression.make_regressor` to score
            (repeats count once); None: the method's ``regressor`` (default linear).
        fit_world_seed: fit the method on the training positions of this other world (it never
            sees the world scored on); the regressions still learn on ``world_seed``'s training
            positions. None: ``world_seed`` itself.
        progress: progress bars.
    """
    config.validate()
    check_world_seed("world_seed", world_seed)
    names = method_regressors(method, regressors)
    data = load(config, world_seed, runs)
    pan, xy, train, test = data.panoramas, data.positions, data.train, data.test
    if fit_world_seed is None or fit_world_seed == world_seed:
        fit_pan = pan[training_sequence(config, train, xy)]
    else:
        check_world_seed("fit_world_seed", fit_world_seed)
        other = load(config, fit_world_seed, runs)
        fit_pan = other.panoramas[training_sequence(config, other.train, other.positions)]
    fitted, f_train, f_test = fitted_features(
        method, fit_pan, config.rotation, pan[train], pan[test], progress=progress
    )
    regressions = {
        name: _evaluate(config, name, f_train, f_test, xy[train], xy[test], world_seed)
        for name in names
    }
    return Scores(config, fitted, invariance_entry(f_train), regressions, data)


def _evaluate(
    config: Config,
    regressor: str,
    f_train: NDArray[np.float64],
    f_test: NDArray[np.float64],
    train_xy: NDArray[np.float64],
    test_xy: NDArray[np.float64],
    world_seed: int,
) -> RegressionScores:
    """The evaluations of :attr:`Config.evaluations` with one regression."""
    found = RegressionScores()
    for evaluation in config.evaluations:
        if evaluation == "train_test":
            found.estimates = fit_predict(make_regressor(regressor), f_train, train_xy, f_test)
            found.train_test = mae(found.estimates, test_xy)
        elif evaluation == "paper_splits":
            found.paper_splits = random_split_mae(
                f_test, test_xy, regressor, n_splits=config.n_splits, seed=config.seed
            )
        else:
            for n_labels in config.labels:
                # each count draws its own labelled positions, the same for every method
                rng = np.random.default_rng([config.seed, world_seed, n_labels])
                chosen = np.sort(rng.choice(len(train_xy), size=n_labels, replace=False))
                estimates = fit_predict(
                    make_regressor(regressor), f_train[chosen], train_xy[chosen], f_test
                )
                found.few_labels[int(n_labels)] = mae(estimates, test_xy)
    return found
