"""The navigation protocol: a feature method trained without labels on the world, its feature
field, and a controller on fixed episode seeds.

1. Training run (:func:`training_run`): panoramas on an ``n x n`` grid over the positions where
   the rover fits and the occupancy grid calls free, in Hilbert-curve order, or a walk that
   steps between neighbouring free cells only (the order shapes the slow features). The method
   is fitted on all simulated rotations of the run in time order.
2. Feature weights: each feature's slowness along that run, to the power ``-weight_power``
   (:func:`~sfa_gym.navigation.feature_gradient.slowness_weights`): unsupervised, no positions.
3. Feature field (:func:`feature_field`): the rotation-averaged features at the nodes of a grid
   of ``field_spacing`` (built once per method and world); the navigation env then steps
   physics only.
4. A controller on episodes ``episode_seed ..``: the slow-feature-gradient controller with
   :class:`~sfa_gym.navigation.controllers.GradientSettings` (``gradient``), or any other
   (:func:`run_controller`). Score: the success rate, with SPL.

The panoramas of the training grid and of the field's nodes come from a
:class:`~sfa_gym.protocols.RunSource` (:class:`~sfa_gym.recording.poses.FreeGridPositions`,
:class:`~sfa_gym.recording.poses.FieldNodes`): they do not depend on the method, so every method
scored on a world reuses them.
"""

from __future__ import annotations

import dataclasses
import datetime
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from sfa_gym._checks import check_int, check_positive, check_positive_int
from sfa_gym.navigation.controllers import GradientSettings
from sfa_gym.phases import phase
from sfa_gym.plugins import FeatureMethod
from sfa_gym.protocols.settings import EnvId, check_choice, check_env_id

__all__ = [
    "FIELD_BATCH",
    "FINGERPRINT_DECIMALS",
    "Config",
    "Scores",
    "TrainingRun",
    "episode_fingerprint",
    "feature_field",
    "fit_features",
    "gradient_controller",
    "prepare",
    "run_controller",
    "score",
    "training_run",
]

FIELD_BATCH = 256
"""Panoramas transformed at a time while filling a field (bounds the memory)."""

FINGERPRINT_DECIMALS = 6
"""Decimals (of a metre, of a radian) the episode fingerprint rounds poses to: 1e-6 m. The physics
defines a pose no finer than its constraint solver's tolerance (MuJoCo's default 1e-8) and a
repeated run differs at most in the last bits of a float reduction (1e-15 m in a 10 m arena), so
a micrometre is above everything the physics leaves open. A real change of the episodes moves a
stop by far more: one 5 ms physics step at 0.4 m/s is 2 mm, and another MuJoCo or a CPU that
rounds ``exp`` differently ends some maze and obstacle episodes 8-25 cm apart
(docs/leaderboard.md)."""

TrainOrder = Literal["hilbert", "walk"]
Headings = Literal["zero", "random"]
HilbertAxes = Literal["xy", "yx"]


@dataclass(frozen=True)
class Config:
    """Settings of the navigation protocol."""

    env_id: EnvId = "sfa_gym/OmniRoverNav-v0"
    """navigation env (sfa_gym/OmniRoverNav-v0, ...Obstacles-v0, ...Maze-v0)"""
    train_grid: int = 30
    """the training run visits an n x n grid of positions (free ones only)"""
    train_order: TrainOrder = "hilbert"
    """order of the training run: "hilbert" (a Hilbert curve through the free grid positions,
    jumping across obstacles and walls) or "walk" (every step between neighbouring free positions
    once each way, never across an obstacle or a wall: a confined random walk's statistics, at
    about four visits per position)"""
    train_headings: Headings = "zero"
    """heading of the rover at the training positions: "zero" (all face +x) or "random" (one
    per grid cell, drawn with seed; the leaderboard's tracks)"""
    hilbert_axes: HilbertAxes = "xy"
    """the grid axes the Hilbert curve's coordinates follow: "xy" or "yx" (the same curve
    mirrored across the diagonal, as the grid localization protocol visits its grid; the
    leaderboard's tracks)"""
    field_spacing: float = 0.1
    """node spacing of the feature fields (m)"""
    episodes: int = 100
    """episodes per controller, on the fields"""
    episode_seed: int = 1000
    """seed of the first episode; episode i uses episode_seed + i"""
    weight_power: float = 2.0
    """the gradient controller's cost weighs each feature by its slowness ** -power (1: the
    commute-time distance, 2: the biharmonic distance)"""
    gradient: GradientSettings = GradientSettings()
    """settings of the slow-feature-gradient controller (the same for every feature method)"""
    seed: int = 0
    """seed of the random training headings and of the renders' resets"""

    def validate(self) -> None:
        """Raise ValueError naming the first bad setting."""
        _check_navigation_env("env_id", self.env_id)
        check_positive_int("train_grid", self.train_grid)
        if self.train_grid < 4:
            raise ValueError(f"train_grid must be at least 4, got {self.train_grid}")
        check_choice("train_order", self.train_order, TrainOrder)
        check_choice("train_headings", self.train_headings, Headings)
        check_choice("hilbert_axes", self.hilbert_axes, HilbertAxes)
        check_positive("field_spacing", self.field_spacing)
        check_positive_int("episodes", self.episodes)
        check_int("episode_seed", self.episode_seed)
        check_positive("weight_power", self.weight_power)
        if not isinstance(self.gradient, GradientSettings):
            raise TypeError(f"gradient must be GradientSettings, got {self.gradient!r}")
        self.gradient.validate()
        check_int("seed", self.seed)
        if self.seed < 0:
            raise ValueError(f"seed must be an int >= 0, got {self.seed}")

    @property
    def episode_seeds(self) -> range:
        """The episodes' reset seeds."""
        return range(self.episode_seed, self.episode_seed + self.episodes)

    def make_env(self, world_seed: int, **kwargs: Any) -> Any:
        """``gym.make(env_id, world_seed=world_seed, **kwargs)``."""
        import gymnasium as gym

        return gym.make(self.env_id, world_seed=world_seed, **kwargs)


def _check_navigation_env(name: str, env_id: Any) -> None:
    """ValueError naming ``name`` unless ``env_id`` is a registered navigation env (its entry
    point an :class:`~sfa_gym.navigation.env.OmniRoverNavEnv`)."""
    import gymnasium as gym
    from gymnasium.envs.registration import load_env_creator

    from sfa_gym.navigation.env import OmniRoverNavEnv

    check_env_id(name, env_id)

    def navigates(spec: Any) -> bool:
        made = spec.entry_point
        made = load_env_creator(made) if isinstance(made, str) else made
        return isinstance(made, type) and issubclass(made, OmniRoverNavEnv)

    if not navigates(gym.spec(env_id)):
        ours = sorted(
            i for i, s in gym.registry.items() if i.startswith("sfa_gym/") and navigates(s)
        )
        raise ValueError(f"{name} {env_id!r} is not a navigation env; expected one of {ours}")


def _request(nav: Any, driver: Any, seed: int) -> Any:
    """The run of ``driver``'s poses in the world of ``nav``, seen by its camera (the exploration
    env of :func:`~sfa_gym.registration.scene_env_id`)."""
    from sfa_gym.recording.cache import RunRequest
    from sfa_gym.registration import scene_env_id

    mirror = getattr(nav, "mirror", None)  # a mirror camera's panorama is its unwarped image
    if mirror is not None:
        height, width = mirror.panorama_height, mirror.panorama_width
    else:
        height, width = nav.panorama.height, nav.panorama.width
    return RunRequest(
        world=nav.world_spec.name,
        world_seed=nav.world_seed,
        panorama=(height, width),
        driver=driver,
        seed=seed,
        env_id=scene_env_id(getattr(getattr(nav, "spec", None), "id", None)),
    )


@dataclass
class TrainingRun:
    """The training run: panoramas of the free grid positions ``(L, H, W, 3)``, their positions
    ``(L, 2)`` and the visiting order ``visits (T,)`` (indices into them; a walk visits a
    position more than once)."""

    panoramas: NDArray[np.uint8]
    positions: NDArray[np.float64]
    visits: NDArray[np.intp]

    @property
    def sequence(self) -> NDArray[np.uint8]:
        """The panoramas in time order ``(T, H, W, 3)``."""
        return self.panoramas[self.visits]


def training_run(config: Config, nav: Any, runs: Any) -> TrainingRun:
    """The training run in the world of ``nav`` (an unwrapped navigation env)."""
    from sfa_gym.recording.ordering import edge_walk
    from sfa_gym.recording.poses import FreeGridPositions

    n = config.train_grid
    driver = FreeGridPositions(
        n,
        seed=config.seed,
        order="hilbert",
        yaw=0.0 if config.train_headings == "zero" else None,
        hilbert_axes=config.hilbert_axes,
    )
    with phase("render"):
        run = runs.get(_request(nav, driver, config.seed))
    # the grid where the rover fits, less the cells the occupancy grid rounds to occupied
    free = np.asarray(nav.occupancy.is_free(run.positions), dtype=bool)
    positions = np.asarray(run.positions, dtype=np.float64)[free]
    panoramas = np.asarray(run.panoramas)[free]
    if config.train_order == "hilbert":
        return TrainingRun(panoramas, positions, np.arange(len(positions)))
    xmin, xmax, ymin, ymax = nav.arena_bounds
    dx, dy = (xmax - xmin) / n, (ymax - ymin) / n
    cells = np.rint((positions - (xmin + dx / 2, ymin + dy / 2)) / (dx, dy)).astype(np.int64)
    # a step may not cross a wall thinner than the grid's spacing: its midpoint must be free
    moves = np.array([(dx, 0.0), (-dx, 0.0), (0.0, dy), (0.0, -dy)])
    middle = (positions[:, None, :] + moves[None] / 2).reshape(-1, 2)
    passable = (nav.occupancy.is_free(middle) & (nav.layout.clearance(middle) > 0)).reshape(-1, 4)
    visits = edge_walk(cells, passable)
    used = np.unique(visits)  # positions the walk cannot reach are left out
    return TrainingRun(panoramas[used], positions[used], np.searchsorted(used, visits))


def fit_features(
    method: FeatureMethod, training: TrainingRun, weight_power: float
) -> tuple[FeatureMethod, NDArray[np.float64], NDArray[np.float64]]:
    """``method`` fitted on every rotation of the training run in time order, the
    rotation-averaged features of the training positions ``(L, k)`` and the feature weights."""
    from sfa_gym.features import fit_method, rotation_averaged_features
    from sfa_gym.navigation.controllers import slowness_weights
    from sfa_gym.rotation import Rotation

    fitted = fit_method(method, training.sequence, Rotation())
    averages = rotation_averaged_features(fitted, training.panoramas, step=1)
    weights = slowness_weights(averages[training.visits], weight_power)
    return fitted, averages, weights


PER_ROTATION_WARNING = 100_000
"""Views a field may ask a method to transform one by one before :func:`_field_features` warns
(a method that is not ``rotation_invariant`` and has no fast path of :mod:`sfa_gym.features`)."""


def _warn_per_rotation(model: Any, n_panoramas: int, width: int) -> None:
    """Warn, with the number of views, when ``model`` will transform every column's rotation of
    each of ``n_panoramas`` field nodes: minutes per field for a slow ``transform``."""
    import warnings

    from sfa_gym.features import averages_view_by_view

    views = n_panoramas * width
    if views > PER_ROTATION_WARNING and averages_view_by_view(model, width):
        name = getattr(model, "name", type(model).__name__)
        warnings.warn(
            f"{name} is not rotation_invariant, so its feature field transforms every "
            f"rotation of each node: {n_panoramas} nodes x {width} columns = {views:,} views. "
            "Declare rotation_invariant (column statistics, see docs/plugins.md) if the "
            "method allows it",
            stacklevel=3,
        )


def _field_features(model: Any, panoramas: Any, rows: NDArray[np.intp]) -> NDArray[np.float64]:
    """Rotation-averaged features (every column) of ``panoramas[rows]``: ``(len(rows), k)``,
    read and transformed ``FIELD_BATCH`` panoramas at a time."""
    from sfa_gym.features import rotation_averaged_features

    _warn_per_rotation(model, len(rows), int(panoramas.shape[2]))

    parts = [
        rotation_averaged_features(model, np.asarray(panoramas[rows[s : s + FIELD_BATCH]]), step=1)
        for s in range(0, len(rows), FIELD_BATCH)
    ]
    features = np.concatenate(parts)
    if not np.all(np.isfinite(features)):
        raise ValueError(f"model {type(model).__name__} returned non-finite features")
    return features


def feature_field(
    nav: Any, model: Any, spacing: float, runs: Any, *, seed: int = 0, model_info: Any = None
) -> Any:
    """The :class:`~sfa_gym.navigation.field.FeatureField` of ``model`` in the world of ``nav``
    (an unwrapped navigation env) at ``spacing`` m, with the nodes' panoramas from ``runs``.

    The field of ``FeatureField.build(camera, model, spacing, free=...)`` (same grid, yaw 0,
    features averaged over every column, non-free nodes filled from the nearest free node, the
    same metadata keys) over the nodes where the rover fits and the occupancy grid calls free.

    Args:
        seed: the reset seed of the nodes' run (part of its key).
        model_info: JSON-serialisable description of the model, stored in the metadata.

    Raises:
        RuntimeError: the run does not hold the nodes the world says it should.
    """
    import sfa_gym
    from sfa_gym.navigation.field import FeatureField, fill_from_free, world_hash
    from sfa_gym.recording.poses import FieldNodes, field_axes

    driver = FieldNodes(spacing)
    request = _request(nav, driver, seed)
    with phase("render"):
        run = runs.get(request)
    nodes, fits = driver.nodes(nav)
    if len(run) != int(fits.sum()) or not np.allclose(run.positions, nodes[fits], atol=1e-6):
        raise RuntimeError(
            f"the run {request.key()} holds {len(run)} panoramas, not the {int(fits.sum())} "
            f"nodes of a {spacing} m field in {nav.world_spec.name!r}, world seed "
            f"{nav.world_seed}"
        )
    free = fits & np.asarray(nav.occupancy.is_free(nodes), dtype=bool)
    rows = np.flatnonzero(free[fits])  # the free nodes' frames in the run
    if not len(rows):
        raise ValueError(f"no free field node at {spacing} m in {nav.world_spec.name!r}")
    values = _field_features(model, run.panoramas, rows)
    features = np.zeros((len(nodes), values.shape[1]))
    features[free] = values
    xs, ys = field_axes(nav.arena_bounds, spacing)
    free2 = free.reshape(len(ys), len(xs))
    grid = fill_from_free(features.reshape(len(ys), len(xs), -1), free2, xs, ys)
    height, width = request.panorama
    metadata = {
        "world": nav.world_spec.name,
        "world_hash": world_hash(nav.world_spec),
        "world_seed": nav.world_seed,
        "panorama": dataclasses.asdict(nav.panorama),
        "panorama_height": int(height),
        "panorama_width": int(width),
        "spacing": float(spacing),
        "node_spacing": [float(xs[1] - xs[0]), float(ys[1] - ys[0])],
        "step": 1,
        "heading": 0.0,
        "n_features": int(grid.shape[2]),
        "n_nodes": int(len(nodes)),
        "n_free": int(free.sum()),
        "model": type(model).__name__,
        "model_info": model_info,
        "render_cache_key": request.key(),
        "sfa_gym_version": sfa_gym.__version__,
        "created": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
    }
    return FeatureField(grid, nav.arena_bounds, free=free2, metadata=metadata)


ControllerMaker = Callable[[Any], Any]
"""``make(env) -> controller`` for an env that observes the feature field."""


@phase("episodes")
def run_controller(
    config: Config,
    world_seed: int,
    field: Any,
    make: ControllerMaker,
    progress: bool = False,
    desc: str | None = None,
) -> list[dict[str, Any]]:
    """The episodes of the controller ``make(env)`` on ``field`` (see
    :func:`~sfa_gym.navigation.evaluate.run_episode`)."""
    from sfa_gym.navigation.evaluate import run_episodes

    env = config.make_env(world_seed, feature_field=field)
    try:
        return run_episodes(env, make(env), config.episode_seeds, progress, desc)
    finally:
        env.close()


def gradient_controller(config: Config, weights: NDArray[np.float64]) -> ControllerMaker:
    """The track's slow-feature-gradient controller on features weighted by ``weights``; it
    sees only the rover's own sensors."""
    from sfa_gym.navigation.controllers import GradientController
    from sfa_gym.navigation.sensors import SensorsOnly

    return lambda env: SensorsOnly(
        GradientController.for_env(env, weights, settings=config.gradient)
    )


@dataclass
class Scores:
    """What scoring one method found.

    Attributes:
        method: the fitted method.
        training: the training run it was fitted on.
        averages: its rotation-averaged features of the training positions ``(L, k)``.
        weights: the feature weights of the controller's cost.
        field: its feature field.
        episodes: the controller's episodes.
    """

    method: Any
    training: TrainingRun
    averages: NDArray[np.float64]
    weights: NDArray[np.float64]
    field: Any
    episodes: list[dict[str, Any]]

    def entry(self) -> dict[str, Any]:
        """The controller's entry of ``results.json`` (see :meth:`entry_of`)."""
        return self.entry_of(self.episodes)

    @staticmethod
    def entry_of(episodes: list[dict[str, Any]]) -> dict[str, Any]:
        """A controller's entry of ``results.json``: its scores over all episodes and the
        interior ones, and the episodes (paths rounded to mm)."""
        from sfa_gym.navigation.evaluate import summarize

        return {
            **summarize(episodes),
            "episodes": [{**e, "path": np.round(e["path"], 3).tolist()} for e in episodes],
        }

    def task_scores(self) -> dict[str, Any]:
        """A leaderboard task's scores (JSON types): ``score`` (the success rate), ``spl``, the
        episode count, the interior episodes' scores, training positions, field nodes and the
        episodes' ``fingerprint`` (:func:`episode_fingerprint`)."""
        from sfa_gym.navigation.evaluate import summarize

        summary = summarize(self.episodes)
        every, interior = summary["all"], summary["interior"]
        return {
            "score": every["success"]["mean"],
            "spl": every["spl"]["mean"],
            "episodes": every["episodes"],
            "interior": {
                "episodes": interior["episodes"],
                # None without an interior episode among them (a small quick size)
                "success": interior["success"]["mean"],
                "spl": interior["spl"]["mean"],
            },
            "training_positions": int(len(self.training.panoramas)),
            "field_nodes": {
                "nodes": self.field.metadata["n_nodes"],
                "free": self.field.metadata["n_free"],
            },
            "fingerprint": episode_fingerprint(self.episodes),
        }


def episode_fingerprint(
    episodes: list[dict[str, Any]], decimals: int = FINGERPRINT_DECIMALS
) -> str:
    """A hash of the episodes: each one's seed, start and goal pose, stop position (the last
    point of its path) and step count, the coordinates rounded to ``decimals``
    (:data:`FINGERPRINT_DECIMALS`). Two runs of the same episodes that agree in it drove the
    same way; a changed MuJoCo, controller, episode sampling or CPU rounding changes it.

    Returns:
        The first 16 hex digits of the SHA-256 of the rounded episodes.
    """
    import hashlib
    import json

    def rounded(values: Any) -> list[str]:
        # + 0.0 turns a rounded -0.0 into 0.0: both signs of zero are the same pose
        return [f"{round(float(v), decimals) + 0.0:.{decimals}f}" for v in values]

    rows = [
        [
            int(e["seed"]),
            rounded(e["start"]),
            rounded(e["goal"]),
            rounded(np.asarray(e["path"], dtype=np.float64)[-1]),
            int(e["steps"]),
        ]
        for e in episodes
    ]
    text = json.dumps(rows, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def prepare(
    config: Config,
    method: FeatureMethod,
    world_seed: int,
    runs: Any,
    *,
    field: Any = None,
) -> Scores:
    """Fit ``method`` on the training run of ``world_seed`` and build its feature field (unless
    the caller kept it: ``field``); the returned scores have no episodes yet."""
    config.validate()
    nav = config.make_env(world_seed).unwrapped
    try:
        training = training_run(config, nav, runs)
        fitted, averages, weights = fit_features(method, training, config.weight_power)
        if field is None:
            info = {
                "method": method.name,
                "cost_weights": weights.tolist(),
                "weight_power": config.weight_power,
            }
            field = feature_field(
                nav, fitted, config.field_spacing, runs, seed=config.seed, model_info=info
            )
    finally:
        nav.close()
    return Scores(fitted, training, averages, weights, field, [])


def score(
    config: Config,
    method: FeatureMethod,
    world_seed: int,
    runs: Any,
    *,
    controller: Callable[[Any, NDArray[np.float64]], Any] | None = None,
    progress: bool = False,
) -> Scores:
    """Fit ``method`` on the training run of ``world_seed``, build its feature field and run
    the controller on the episodes (:func:`prepare`, :func:`run_controller`). Writes no files.

    Args:
        runs: the rendered runs (:class:`~sfa_gym.protocols.RunSource`).
        controller: ``controller(env, weights) -> controller`` instead of the gradient
            controller of ``config.gradient``.
        progress: progress bars.
    """
    found = prepare(config, method, world_seed, runs)
    weights = found.weights
    if controller is None:
        make = gradient_controller(config, weights)
    else:
        make = lambda env: controller(env, weights)  # noqa: E731
    desc = f"gradient on {method.name}"
    found.episodes = run_controller(config, world_seed, found.field, make, progress, desc)
    return found
