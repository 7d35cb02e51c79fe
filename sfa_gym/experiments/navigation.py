"""The navigation protocol: train a feature method without labels on the world, build its feature
field, and run navigation controllers on fixed episode seeds.

1. Training run: panoramas on an ``n x n`` grid over the free space, visited in Hilbert-curve
   order or along a walk that steps between neighbouring free cells only (the order shapes the
   slow features, as in the localization protocol); hierarchical SFA is fitted on all their
   simulated rotations.
2. Feature weights: each feature's slowness along that training sequence, to the power
   ``-weight_power`` (:func:`~sfa_gym.navigation.controllers.slowness_weights`): unsupervised,
   no positions.
3. Feature field (:class:`~sfa_gym.navigation.field.FeatureField`): the rotation-averaged
   features on a grid of ``field_spacing``; the navigation env then steps physics only.
4. Controllers on ``episodes`` seeds: the slow-feature-gradient controller on each feature
   method, the oracle (ground truth and map: the upper bound) and the random policy (the floor);
   optionally some episodes rendered, with features computed from the panoramas.

Everything is cached in the output folder (the model, the fields), so a second run with other
controllers or more episodes reuses it.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sfa_gym._checks import check_int, check_positive, check_positive_int
from sfa_gym.experiments.report import check_out_folder
from sfa_gym.navigation.controllers import GradientSettings
from sfa_gym.protocols.settings import EnvId, SFASettings, check_env_id

__all__ = ["NavigationExperiment", "format_navigation_table", "run_navigation_experiment"]

CONTROLLERS = ("gradient", "oracle", "random")
TRAIN_ORDERS = ("hilbert", "walk")


@dataclass(frozen=True)
class NavigationExperiment:
    """Settings of the navigation protocol."""

    env_id: EnvId = "sfa_gym/OmniRoverNav-v0"
    """navigation env (sfa_gym/OmniRoverNav-v0, ...Obstacles-v0, ...Maze-v0)"""
    world_seed: int = 0
    """seed of the world's procedural variation"""
    train_grid: int = 30
    """the training run visits an n x n grid of positions (free ones only)"""
    train_order: str = "hilbert"
    """order of the training run: "hilbert" (a Hilbert curve through the free grid positions,
    jumping across obstacles and walls) or "walk" (every step between neighbouring free positions
    once each way, never across an obstacle or a wall: a confined random walk's statistics, at
    about four visits per position)"""
    field_spacing: float = 0.1
    """node spacing of the feature fields (m)"""
    episodes: int = 100
    """episodes per controller, on the fields"""
    episode_seed: int = 1000
    """seed of the first episode; episode i uses episode_seed + i"""
    rendered_episodes: int = 0
    """episodes of the gradient controller on SFA that render panoramas (slow: ~0.1 s a step)"""
    weight_power: float = 2.0
    """the gradient controller's cost weighs each feature by its slowness ** -power (1: the
    commute-time distance, 2: the biharmonic distance)"""
    controllers: tuple[str, ...] = CONTROLLERS
    """controllers to run: gradient (on every feature method), oracle, random"""
    sfa: SFASettings = SFASettings(node_dim=16, n_outputs=8)
    """the hierarchical SFA network"""
    gradient: GradientSettings = GradientSettings()
    """settings of the slow-feature-gradient controller (the same for every feature method)"""

    def validate(self) -> None:
        """Raise ValueError naming the first bad setting."""
        check_env_id("env_id", self.env_id)
        check_int("world_seed", self.world_seed)
        check_positive_int("train_grid", self.train_grid)
        if self.train_grid < 4:
            raise ValueError(f"train_grid must be at least 4, got {self.train_grid}")
        if self.train_order not in TRAIN_ORDERS:
            raise ValueError(
                f"train_order must be one of {list(TRAIN_ORDERS)}, got {self.train_order!r}"
            )
        check_positive("field_spacing", self.field_spacing)
        check_positive_int("episodes", self.episodes)
        check_int("episode_seed", self.episode_seed)
        check_int("rendered_episodes", self.rendered_episodes)
        check_positive("weight_power", self.weight_power)
        unknown = sorted(set(self.controllers) - set(CONTROLLERS))
        if unknown or not self.controllers:
            raise ValueError(f"controllers must be among {list(CONTROLLERS)}, got {unknown}")
        self.sfa.validate()
        self.gradient.validate()


def _training_run(
    config: NavigationExperiment, nav: Any, camera: Any, progress: bool
) -> tuple[NDArray[np.uint8], NDArray[np.int64]]:
    """Panoramas of the free grid positions ``(L, H, W, 3)`` and the training run's visiting
    order ``(T,)`` (indices into them; a walk visits a position more than once)."""
    from tqdm import tqdm

    from sfa_gym.recording.ordering import edge_walk, grid_order

    n = config.train_grid
    positions = nav.grid_positions(n)
    cells = np.stack(np.unravel_index(np.arange(n * n), (n, n)), axis=1)[:, ::-1]  # (i=x, j=y)
    order = grid_order(cells, "hilbert")
    positions, cells = positions[order], cells[order]
    # the env refuses poses closer to an obstacle than the footprint radius; a free cell
    # reaches up to half a cell diagonal closer
    ok = nav.layout.clearance(positions) > nav.rover.footprint_radius
    keep = nav.occupancy.is_free(positions) & ok
    positions, cells = positions[keep], cells[keep]
    if config.train_order == "hilbert":
        visits = np.arange(len(positions))
    else:
        # a step may not cross a wall thinner than the grid's spacing: its midpoint must be free
        xmin, xmax, ymin, ymax = nav.arena_bounds
        dx, dy = (xmax - xmin) / n, (ymax - ymin) / n
        moves = np.array([(dx, 0.0), (-dx, 0.0), (0.0, dy), (0.0, -dy)])
        middle = positions[:, None, :] + moves[None] / 2
        passable = nav.occupancy.is_free(middle.reshape(-1, 2)).reshape(-1, 4)
        passable &= (nav.layout.clearance(middle.reshape(-1, 2)) > 0).reshape(-1, 4)
        visits = edge_walk(cells, passable)
        used = np.unique(visits)  # positions the walk cannot reach are left out
        positions, visits = positions[used], np.searchsorted(used, visits)
    panoramas = np.stack(
        [
            camera.reset(options={"pose": (x, y, 0.0)})[0]
            for x, y in tqdm(positions, desc="training run", disable=not progress)
        ]
    )
    return panoramas, visits


def _fit_sfa(
    config: NavigationExperiment, panoramas: NDArray[np.uint8], path: Path, progress: bool
):
    from sfa_gym.sfa.io import load_model, save_model

    if path.exists():
        return load_model(path)
    _, h, w, _ = panoramas.shape
    model = config.sfa.make_model(h, w, progress).fit_rotations(panoramas, step=5)
    save_model(model, path)
    return model


def _field(
    camera: Any,
    nav: Any,
    model: Any,
    path: Path,
    config: NavigationExperiment,
    name: str,
    weights: NDArray[np.float64],
    progress: bool,
):
    from sfa_gym.navigation.field import FeatureField

    if path.exists():
        return FeatureField.load(path)
    field = FeatureField.build(
        camera,
        model,
        spacing=config.field_spacing,
        free=lambda p: (
            nav.occupancy.is_free(p) & (nav.layout.clearance(p) > nav.rover.footprint_radius)
        ),
        progress=progress,
        # the cost weights travel with the field: agents trained on it later need them
        model_info={
            "method": name,
            "cost_weights": weights.tolist(),
            "weight_power": config.weight_power,
        },
    )
    field.save(path)
    return field


def _embedded_field(base: Any, embedding: Any, path: Path, name: str, weights: NDArray):
    """The field of :class:`~sfa_gym.features.EmbeddedFeatures` from its base model's field: the
    embedding of the base's rotation-averaged features at every node (nothing rendered)."""
    from sfa_gym.navigation.field import FeatureField

    if path.exists():
        return FeatureField.load(path)
    ny, nx, k = base.values.shape
    values = embedding.transform(base.values.reshape(-1, k)).reshape(ny, nx, -1)
    model_info = {**base.metadata.get("model_info", {}), "method": name}
    model_info["cost_weights"] = weights.tolist()
    metadata = {**base.metadata, "model_info": model_info}
    field = FeatureField(
        values, base.bounds, free=base.free, metadata=metadata, interpolation=base.interpolation
    )
    field.save(path)
    return field


def _controller_entry(episodes: list[dict[str, Any]]) -> dict[str, Any]:
    """A controller's scores and its episodes (paths rounded to mm) for ``results.json``."""
    from sfa_gym.navigation.evaluate import summarize

    return {
        **summarize(episodes),
        "episodes": [{**e, "path": np.round(e["path"], 3).tolist()} for e in episodes],
    }


def run_navigation_experiment(
    config: NavigationExperiment,
    out_dir: str | Path,
    methods: list[tuple[Any, Any]] | None = None,
    progress: bool = True,
) -> dict[str, Any]:
    """Run the protocol (module docstring); write ``results.json`` and figures to ``out_dir``.

    ``methods`` are extra feature methods (plug-ins, as for localization) that get the gradient
    controller beside hierarchical SFA.
    """
    import gymnasium as gym
    import matplotlib.pyplot as plt

    from sfa_gym._files import write_json_atomic
    from sfa_gym.features import EmbeddedFeatures, rotation_averaged_features
    from sfa_gym.navigation.controllers import (
        GradientController,
        OracleController,
        RandomController,
        slowness_weights,
    )
    from sfa_gym.navigation.evaluate import run_episodes
    from sfa_gym.navigation.plots import paths
    from sfa_gym.protocols.features import fit_method
    from sfa_gym.rotation import Rotation
    from sfa_gym.sfa.graph import WalkGraphEmbedding
    from sfa_gym.sim.env import OmniRoverEnv
    from sfa_gym.wrappers import GoalFeatureObservation

    config.validate()
    out = Path(out_dir)
    check_out_folder(out)
    out.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    nav = gym.make(config.env_id, world_seed=config.world_seed).unwrapped
    seeds = range(config.episode_seed, config.episode_seed + config.episodes)

    # renders the training run and the fields (the navigation env has no pose option)
    camera = OmniRoverEnv(nav.world, nav.world_seed, nav.panorama)
    panoramas, visits = _training_run(config, nav, camera, progress)
    train = panoramas[visits]  # the training run in time order
    models: dict[str, Any] = {"sfa": _fit_sfa(config, train, out / "sfa_model.npz", progress)}
    for method, _ in methods or []:
        models[method.name] = fit_method(method, train, Rotation())

    results: dict[str, Any] = {
        "protocol": "navigation",
        "settings": dataclasses.asdict(config),
        "training_positions": len(panoramas),
        "training_visits": len(visits),
        "controllers": {},
    }
    weights: dict[str, NDArray[np.float64]] = {}
    fields: dict[str, Any] = {}
    for name, model in list(models.items()):
        averages = rotation_averaged_features(model, panoramas, step=1)
        weights[name] = slowness_weights(averages[visits], config.weight_power)
        fields[name] = _field(
            camera, nav, model, out / f"field_{name}.npz", config, name, weights[name], progress
        )
        if config.train_order == "walk":
            # the slowest functions of the walk's graph, read at a place from the training
            # places whose features are most like its own
            graph = f"{name}_graph"
            embedding = WalkGraphEmbedding(config.sfa.n_outputs).fit(averages, visits)
            models[graph] = EmbeddedFeatures(model, embedding, graph)
            weights[graph] = slowness_weights(
                embedding.transform(averages)[visits], config.weight_power
            )
            fields[graph] = _embedded_field(
                fields[name], embedding, out / f"field_{graph}.npz", graph, weights[graph]
            )
    camera.close()

    for name, field in fields.items():
        env = gym.make(config.env_id, world_seed=config.world_seed, feature_field=field)
        runs: list[tuple[str, Any]] = []
        if "gradient" in config.controllers:
            controller = GradientController.for_env(env, weights[name], settings=config.gradient)
            runs.append((f"gradient/{name}", controller))
            _landscape_figure(field, weights[name], nav, out / f"cost_landscape_{name}.png", name)
        if name == "sfa":
            runs += [
                (kind, make.for_env(env))
                for kind, make in (("oracle", OracleController), ("random", RandomController))
                if kind in config.controllers
            ]
        for label, controller in runs:
            episodes = run_episodes(env, controller, seeds, progress, label)
            results["controllers"][label] = _controller_entry(episodes)
            if label.startswith("gradient/"):
                fig, _ = paths(episodes, nav.occupancy, f"gradient on {name}:")
                fig.savefig(out / f"paths_gradient_{name}.png", dpi=110, bbox_inches="tight")
                plt.close(fig)
        env.close()

    rendered = range(config.episode_seed, config.episode_seed + config.rendered_episodes)
    for name in ("sfa", "sfa_graph"):
        if config.rendered_episodes <= 0 or name not in models:
            continue
        env = GoalFeatureObservation(
            gym.make(config.env_id, world_seed=config.world_seed), models[name]
        )
        controller = GradientController.for_env(env, weights[name], settings=config.gradient)
        episodes = run_episodes(
            env, controller, rendered, progress, f"gradient on {name}, rendered"
        )
        results["controllers"][f"gradient/{name}/rendered"] = _controller_entry(episodes)
        env.close()

    results["seconds"] = round(time.perf_counter() - started, 1)
    write_json_atomic(out / "results.json", results)
    return results


def _landscape_figure(field: Any, weights: NDArray, nav: Any, path: Path, name: str) -> None:
    """The cost of a goal near a corner of the free space over the arena."""
    import matplotlib.pyplot as plt

    from sfa_gym.navigation.plots import cost_landscape

    gx, gy = np.meshgrid(field.xs, field.ys)
    nodes = np.stack([gx.ravel(), gy.ravel()], axis=1)
    free = nav.occupancy.is_free(nodes)
    xmin, xmax, ymin, ymax = nav.arena_bounds
    goal = np.array([xmin + 0.25 * (xmax - xmin), ymin + 0.25 * (ymax - ymin)])
    values = field(nodes)
    cost = np.sum(weights * (values - field(goal[None])[0]) ** 2, axis=1)
    cost[~free] = math.nan
    fig, _ = cost_landscape(nodes, cost, goal, title=f"cost of a goal, {name} features")
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)


def format_navigation_table(results: dict[str, Any]) -> str:
    """Success and SPL (mean and 95 % interval) per controller, all pairs and interior pairs."""
    lines = [
        "| controller | success, all | SPL, all | success, interior | SPL, interior | episodes |",
        "|---|---|---|---|---|---|",
    ]
    for name, entry in results["controllers"].items():
        cells = []
        for group in ("all", "interior"):
            for key in ("success", "spl"):
                score = entry[group][key]
                lo, hi = score["ci95"]
                if score["mean"] is None:
                    cells.append("-")
                else:
                    cells.append(f"{score['mean']:.2f} ({lo:.2f}-{hi:.2f})")
        episodes = f"{entry['all']['episodes']} ({entry['interior']['episodes']} interior)"
        lines.append(f"| {name} | " + " | ".join(cells) + f" | {episodes} |")
    return "\n".join(lines)
