"""``sfa-gym navigate``: the navigation protocol (:mod:`sfa_gym.protocols.navigation`) for
hierarchical SFA and the plug-in feature methods, beside the oracle (upper bound) and the random
policy (the floor), with its output folder, results (JSON and a table) and figures.

The renders (training grid, field nodes) are kept in ``<out>/renders``, the SFA model and the
feature fields in ``<out>``, so a second run with other controllers or more episodes reuses
them; ``<out>/stored_settings.json`` records the settings they were made with, and a run with
other settings computes them again. Extras of the command line: with ``train_order="walk"``
each method's walk-graph twin ``<method>_graph`` (the slowest functions of the walk's graph,
read at a place from the training places whose features are most like its own), and episodes
that render panoramas.
"""

from __future__ import annotations

import dataclasses
import json
import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import tyro
from numpy.typing import NDArray

from sfa_gym._checks import check_int, check_world_seed
from sfa_gym.cli.results import check_out_folder
from sfa_gym.intervals import format_interval
from sfa_gym.protocols import navigation as protocol
from sfa_gym.protocols.settings import SFASettings
from sfa_gym.protocols.slow_features import SlowFeatureMethod
from sfa_gym.rotation import Rotation

__all__ = [
    "Navigate",
    "NavigationExperiment",
    "format_navigation_table",
    "run_navigation_experiment",
]

CONTROLLERS = ("gradient", "oracle", "random")
STORED_SETTINGS = "stored_settings.json"
# the settings that make the stored model and fields (the episodes and controllers do not)
_STORED = (
    "env_id", "world_seed", "train_grid", "train_order", "train_headings", "hilbert_axes",
    "seed", "field_spacing", "weight_power", "sfa",
)  # fmt: skip


@dataclass(frozen=True)
class NavigationExperiment(protocol.Config):
    """Settings of the navigation protocol, a world, the SFA network and the controllers."""

    world_seed: int = 0
    """seed of the world's procedural variation"""
    rendered_episodes: int = 0
    """episodes of the gradient controller on SFA that render panoramas (slow: ~0.1 s a step)"""
    controllers: tuple[str, ...] = CONTROLLERS
    """controllers to run: gradient (on every feature method), oracle, random"""
    sfa: SFASettings = SFASettings(node_dim=16, n_outputs=8)
    """the hierarchical SFA network"""

    def validate(self) -> None:
        """Raise ValueError naming the first bad setting."""
        super().validate()
        check_world_seed("world_seed", self.world_seed)
        if check_int("rendered_episodes", self.rendered_episodes) < 0:
            raise ValueError(f"rendered_episodes must be >= 0, got {self.rendered_episodes}")
        unknown = sorted(set(self.controllers) - set(CONTROLLERS))
        if unknown or not self.controllers:
            raise ValueError(f"controllers must be among {list(CONTROLLERS)}, got {unknown}")
        self.sfa.validate()


class _StoredSFA(SlowFeatureMethod):
    """Hierarchical SFA fitted on every 5-column rotation of the training run, kept in
    ``path`` and read back from there by the next run into the same folder."""

    name = "sfa"

    def __init__(self, settings: SFASettings, path: Path, progress: bool) -> None:
        super().__init__(settings, Rotation(step=5), progress)
        self.path = path

    def fit_rotations(self, panoramas: NDArray[np.uint8], appearances: int = 1) -> _StoredSFA:
        from sfa_gym.sfa.io import load_model, save_model

        if not self.path.exists():
            save_model(super().fit_rotations(panoramas, appearances).model_, self.path)
            return self
        self.model_ = load_model(self.path)
        self.input_shape_ = self.model_.input_shape_
        return self


def _stored_settings(config: NavigationExperiment) -> dict[str, Any]:
    settings = dataclasses.asdict(config)
    return json.loads(json.dumps({name: settings[name] for name in _STORED}))


def check_stored(out: Path, config: NavigationExperiment) -> list[str]:
    """Make the model and fields stored in ``out`` those of ``config``: when they were made
    with other settings (or with settings not recorded), delete them so that they are computed
    again. Returns the differing settings (empty when the stored ones are reused)."""
    wanted = _stored_settings(config)
    record = out / STORED_SETTINGS
    kept = [p for p in (out / "sfa_model.npz", *out.glob("field_*.npz")) if p.exists()]
    have = json.loads(record.read_text()) if record.is_file() else None
    differing: list[str] = []
    if kept and have != wanted:
        if have is None:
            differing = ["(settings not recorded)"]
        else:
            differing = [n for n in _STORED if have.get(n) != wanted[n]]
        for path in kept:
            path.unlink()
    record.write_text(json.dumps(wanted, indent=2) + "\n")
    return differing


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
    import matplotlib.pyplot as plt

    from sfa_gym.features import EmbeddedFeatures
    from sfa_gym.files import write_json_atomic
    from sfa_gym.navigation.controllers import (
        GradientController,
        OracleController,
        RandomController,
        slowness_weights,
    )
    from sfa_gym.navigation.evaluate import run_episodes
    from sfa_gym.navigation.field import FeatureField
    from sfa_gym.navigation.plots import paths
    from sfa_gym.recording.cache import RunCache
    from sfa_gym.sfa.graph import WalkGraphEmbedding
    from sfa_gym.wrappers import GoalFeatureObservation

    config.validate()
    out = Path(out_dir)
    check_out_folder(out)
    out.mkdir(parents=True, exist_ok=True)
    differing = check_stored(out, config)
    if differing:
        print(
            f"{out}: the stored SFA model and feature fields were made with other settings "
            f"({', '.join(differing)}); computing them again"
        )
    started = time.perf_counter()
    runs = RunCache(out / "renders", progress=progress)
    nav = config.make_env(config.world_seed).unwrapped
    evaluated = [_StoredSFA(config.sfa, out / "sfa_model.npz", progress)]
    evaluated += [method for method, _ in methods or []]

    models: dict[str, Any] = {}
    weights: dict[str, NDArray[np.float64]] = {}
    fields: dict[str, Any] = {}
    for method in evaluated:
        name = method.name
        path = out / f"field_{name}.npz"
        kept = FeatureField.load(path) if path.exists() else None
        found = protocol.prepare(config, method, config.world_seed, runs, field=kept)
        if kept is None:
            found.field.save(path)
        training = found.training
        model = found.method.model_ if isinstance(found.method, _StoredSFA) else found.method
        models[name], weights[name], fields[name] = model, found.weights, found.field
        if config.train_order == "walk":
            graph = f"{name}_graph"
            embedding = WalkGraphEmbedding(config.sfa.n_outputs).fit(
                found.averages, training.visits
            )
            models[graph] = EmbeddedFeatures(model, embedding, graph)
            weights[graph] = slowness_weights(
                embedding.transform(found.averages)[training.visits], config.weight_power
            )
            fields[graph] = _embedded_field(
                found.field, embedding, out / f"field_{graph}.npz", graph, weights[graph]
            )

    results: dict[str, Any] = {
        "protocol": "navigation",
        "settings": dataclasses.asdict(config),
        "training_positions": len(training.panoramas),
        "training_visits": len(training.visits),
        "controllers": {},
    }
    for name, field in fields.items():
        runs_of: list[tuple[str, Any]] = []
        if "gradient" in config.controllers:
            runs_of.append(
                (f"gradient/{name}", protocol.gradient_controller(config, weights[name]))
            )
            _landscape_figure(field, weights[name], nav, out / f"cost_landscape_{name}.png", name)
        if name == "sfa":
            runs_of += [
                (kind, make.for_env)
                for kind, make in (("oracle", OracleController), ("random", RandomController))
                if kind in config.controllers
            ]
        for label, make in runs_of:
            episodes = protocol.run_controller(
                config, config.world_seed, field, make, progress, label
            )
            results["controllers"][label] = protocol.Scores.entry_of(episodes)
            if label.startswith("gradient/"):
                fig, _ = paths(episodes, nav.occupancy, f"gradient on {name}:")
                fig.savefig(out / f"paths_gradient_{name}.png", dpi=110, bbox_inches="tight")
                plt.close(fig)

    rendered = range(config.episode_seed, config.episode_seed + config.rendered_episodes)
    for name in ("sfa", "sfa_graph"):
        if config.rendered_episodes <= 0 or name not in models:
            continue
        env = GoalFeatureObservation(config.make_env(config.world_seed), models[name])
        controller = GradientController.for_env(env, weights[name], settings=config.gradient)
        episodes = run_episodes(
            env, controller, rendered, progress, f"gradient on {name}, rendered"
        )
        results["controllers"][f"gradient/{name}/rendered"] = protocol.Scores.entry_of(episodes)
        env.close()
    nav.close()

    results["seconds"] = round(time.perf_counter() - started, 1)
    write_json_atomic(out / "results.json", results)
    return results


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
                if score["mean"] is None:
                    cells.append("-")
                else:
                    interval = format_interval(score["ci95"], entry[group]["episodes"])
                    cells.append(f"{score['mean']:.2f} {interval}")
        episodes = f"{entry['all']['episodes']} ({entry['interior']['episodes']} interior)"
        lines.append(f"| {name} | " + " | ".join(cells) + f" | {episodes} |")
    return "\n".join(lines)


@dataclass(frozen=True)
class Navigate:
    """Image-goal navigation: the slow-feature-gradient controller on SFA and on the feature
    methods of a folder of plug-in files, beside the oracle (upper bound) and a random policy."""

    out: Path
    """output folder (created); the renders, the SFA model and the feature fields are kept there
    and reused while the settings that made them stay the same (else computed again)"""
    settings: tyro.conf.OmitArgPrefixes[NavigationExperiment] = NavigationExperiment()
    """settings of the navigation protocol"""
    baselines: Path | None = None
    """folder of feature-method plug-in files (default: none; e.g. baselines/); each runs in a
    worker process of its own"""
    quiet: bool = False
    """no progress bars"""

    def run(self) -> int:
        from sfa_gym.cli.baselines import baseline_workers

        self.settings.validate()
        with baseline_workers(self.out, self.baselines, use_default=False) as methods:
            results = run_navigation_experiment(
                self.settings, self.out, methods, progress=not self.quiet
            )
        table = format_navigation_table(results)
        Path(self.out, "results.txt").write_text(table + "\n")
        print(table)
        print(f"results in {Path(self.out) / 'results.json'}; figures in {self.out}")
        return 0
