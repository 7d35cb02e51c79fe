"""``sfa-gym localize``, ``localize-run`` and ``localize-outdoor``: a localization protocol
(:mod:`sfa_gym.protocols`: ``grid``, the paper's simulator protocol; ``trajectory``, its outdoor
protocol on driven runs; ``outdoor``, the outdoor world with its appearance tracks) scoring
hierarchical SFA beside the feature methods of a folder of plug-in files, written to an output
folder: the runs (reused or resumed by the next call with the same settings), ``results.json``,
``results.txt``, ``sfa_model.npz`` and figures.

Every method is scored through its protocol's ``score`` (the code the leaderboard scores with):
hierarchical SFA first, with :data:`SFA_REGRESSORS`, each plug-in with the regressions it names.
Every field of the settings (:class:`GridExperiment`, :class:`TrajectoryExperiment`,
:class:`OutdoorExperiment`, the nested :class:`~sfa_gym.protocols.settings.SFASettings`) is an
option of the same name, without prefix (``--n-train``, ``--node-dim``); their docstrings are the
help text and their ``validate()`` checks the values.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import tyro
from numpy.typing import NDArray

from sfa_gym._checks import check_world_seed
from sfa_gym.cli.baselines import baseline_workers
from sfa_gym.cli.figures import FIGURE_REGRESSOR
from sfa_gym.cli.results import check_out_folder, format_table, results_header, write_results
from sfa_gym.plugins import FeatureMethod
from sfa_gym.protocols import grid, outdoor, trajectory
from sfa_gym.protocols.settings import SFASettings
from sfa_gym.protocols.slow_features import SlowFeatureMethod

__all__ = [
    "PAPER_OUTDOOR_RESULTS",
    "PAPER_SIM_RESULTS",
    "SFA_REGRESSORS",
    "GridExperiment",
    "Localize",
    "LocalizeOutdoor",
    "LocalizeRun",
    "OutdoorExperiment",
    "TrajectoryExperiment",
    "run_grid_experiment",
    "run_outdoor_experiment",
    "run_trajectory_experiment",
]

Methods = Sequence[tuple[FeatureMethod, Sequence[str]]]

SFA_REGRESSORS = ("linear", "quadratic", "map")
"""Regressions hierarchical SFA is evaluated with: the paper's linear one, a quadratic one and
the map decoder."""

PAPER_SIM_RESULTS = {"mae_percent": [1.83, 1.68], "eta_phi_max": 0.17}
"""The paper's simulator figures: MAE (x, z) in % of the range over 100 random 50/50 splits."""

PAPER_OUTDOOR_RESULTS = {
    "mae_m": [0.23, 0.175],
    "mae_percent": [5.3, 3.7],
    "std_m": [0.20, 0.13],
    "eta_phi_min": 0.0,
    "eta_phi_max": 0.05,
}
"""The paper's outdoor figures: regression fitted on the training run, MAE (x, z) on the test
run in metres and in % of its range, standard deviations (m), range of eta_phi over outputs."""


class _WorldAndNetwork:
    """A protocol's ``Config`` (:attr:`config_type`) with the command's own fields added: the
    world seed and the SFA network."""

    config_type: ClassVar[type]
    world_seed: int
    sfa: SFASettings

    def validate(self) -> None:
        """Raise ValueError (or TypeError) naming the first bad setting."""
        super().validate()  # type: ignore[misc]
        check_world_seed("world_seed", self.world_seed)
        self.sfa.validate()

    def protocol(self) -> Any:
        """The protocol's own settings."""
        names = [f.name for f in dataclasses.fields(self.config_type)]
        return self.config_type(**{name: getattr(self, name) for name in names})


@dataclass(frozen=True)
class GridExperiment(_WorldAndNetwork, grid.Config):
    """Settings of ``sfa-gym localize``: the grid protocol's (:class:`grid.Config
    <sfa_gym.protocols.grid.Config>`), the world seed and the SFA network (defaults: the
    paper's simulator experiment)."""

    config_type: ClassVar[type] = grid.Config
    world_seed: int = 0
    """seed of the world's procedural variation (>= 0)"""
    sfa: SFASettings = SFASettings()
    """the hierarchical SFA network"""


@dataclass(frozen=True)
class TrajectoryExperiment(_WorldAndNetwork, trajectory.Config):
    """Settings of ``sfa-gym localize-run``: the trajectory protocol's (:class:`trajectory.Config
    <sfa_gym.protocols.trajectory.Config>`), the world seed and the SFA network (defaults: the
    paper's outdoor experiment, scaled to the 6 x 6 m ``paper_sim`` arena)."""

    config_type: ClassVar[type] = trajectory.Config
    world_seed: int = 0
    """seed of the world's procedural variation (>= 0)"""
    sfa: SFASettings = SFASettings()
    """the hierarchical SFA network"""


@dataclass(frozen=True)
class OutdoorExperiment(_WorldAndNetwork, outdoor.Config):
    """Settings of the outdoor protocol (defaults: the paper's), a world and the SFA network."""

    config_type: ClassVar[type] = outdoor.Config
    world_seed: int = 0
    """seed of the world's procedural variation (scenery, clouds, movers)"""
    sfa: SFASettings = SFASettings(network="auto")
    """the hierarchical SFA network (auto: paper_outdoor at the paper's 60 x 600, paper_sim at
    40 x 350)"""


def _output_folder(config: Any, out_dir: str | os.PathLike[str]) -> Path:
    """``out_dir``, created, once ``config`` has been checked."""
    config.validate()
    out = Path(out_dir)
    check_out_folder(out)
    out.mkdir(parents=True, exist_ok=True)
    return out


def _score_in_folder(module: Any, config: Any, out: Path, methods: Methods, progress: bool):
    """The ``Scores`` of hierarchical SFA and then of every method, by ``module.score`` on the
    runs recorded in ``out``, and the protocol's settings."""
    from sfa_gym.recording.cache import RunFolder

    protocol = config.protocol()
    runs = RunFolder(out, module.requests(protocol, config.world_seed), progress=progress)
    sfa = SlowFeatureMethod(config.sfa, protocol.rotation, progress=progress)
    found = [
        module.score(protocol, method, config.world_seed, runs, regressors=regs, progress=progress)
        for method, regs in [(sfa, SFA_REGRESSORS), *methods]
    ]
    return found, protocol


def _write(out: Path, model: Any, results: dict[str, Any]) -> dict[str, Any]:
    from sfa_gym.sfa.io import save_model

    save_model(model, out / "sfa_model.npz")
    return write_results(out / "results.json", results)


def run_grid_experiment(
    config: GridExperiment,
    out_dir: str | os.PathLike[str],
    methods: Methods = (),
    progress: bool = True,
    figures: bool = True,
) -> dict[str, Any]:
    """Run the grid protocol; write ``results.json``, ``sfa_model.npz`` and figures (firing
    maps, estimates, error map). The rendered grid is kept in ``out_dir`` as ``grid.run``.
    Two evaluations per regression by default: ``paper_splits`` (the paper's 100 random 50/50
    splits of the test positions) and ``train_test`` (fitted on the training positions).
    Returns the results as written to ``results.json``."""
    out = _output_folder(config, out_dir)
    found, _ = _score_in_folder(grid, config, out, methods, progress)
    data, model = found[0].data, found[0].method.model_
    results = _write(
        out,
        model,
        {
            **results_header("grid", config, data.panoramas.shape[2], config.step),
            "paper": PAPER_SIM_RESULTS,
            "methods": {scores.method.name: scores.entry() for scores in found},
        },
    )
    if figures:
        from sfa_gym.cli.figures import grid_figures

        grid_figures(out, found[0])
    return results


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
    methods: Methods = (),
    progress: bool = True,
    figures: bool = True,
) -> dict[str, Any]:
    """Run the trajectory protocol; write ``results.json`` (per method and regression
    ``train_test``, ``excluded``, ``visited``; ``eta_r``, ``eta_phi``), ``sfa_model.npz`` and
    figures (trajectories, estimates, error map, firing maps). The runs are kept in ``out_dir``
    as ``train.run`` and ``test.run``. Returns the results as written to ``results.json``."""
    out = _output_folder(config, out_dir)
    found, protocol = _score_in_folder(trajectory, config, out, methods, progress)
    data, model = found[0].data, found[0].method.model_
    results = _write(
        out,
        model,
        {
            **results_header("trajectory", config, data.train_pan.shape[2], config.step),
            "eval_windows": data.windows.tolist(),
            "runs": {
                "train": _run_summary(data.train_run, data.train_idx, data.train_inside),
                "test": _run_summary(data.test_run, data.test_idx, data.test_inside),
            },
            "paper": PAPER_OUTDOOR_RESULTS,
            "methods": {scores.method.name: scores.entry() for scores in found},
        },
    )
    if figures:
        from sfa_gym.cli.figures import trajectory_figures

        trajectory_figures(
            out,
            exclude=config.exclude,
            model=model,
            rotation=protocol.rotation,
            train_run=data.train_run,
            test_run=data.test_run,
            train_pan=data.train_pan,
            train_xy=data.train_xy,
            test_xy=data.test_xy,
            test_time=data.test_run.time[data.test_idx],
            estimates=found[0].regressions[FIGURE_REGRESSOR].estimates,
        )
    return results


class FolderRuns:
    """The outdoor protocol's runs, recorded into an output folder under readable names
    (``drive.run``, ``test_<condition>.run``, ``train_<hours>h.run``) and resumed when
    incomplete: the :class:`~sfa_gym.protocols.RunSource` of ``sfa-gym localize-outdoor``."""

    def __init__(self, out: Path, config: outdoor.Config, world_seed: int, progress: bool):
        self.progress = progress
        self.default_panorama = config.panorama is None
        self.paths = {}
        for name, request in outdoor.requests(config, world_seed).items():
            file = name if name.startswith(("drive", "train_")) else f"test_{name}"
            self.paths[request.key()] = out / f"{file}.run"

    def get(self, request: Any) -> Any:
        from sfa_gym.recording.recorder import record

        kwargs = {"world_seed": request.world_seed, **request.env_kwargs}
        if not self.default_panorama:
            kwargs["panorama"] = request.panorama_spec()
        return record(
            request.env_id,
            request.driver,
            self.paths[request.key()],
            seed=request.seed,
            env_kwargs=kwargs,
            progress=self.progress,
        )


def run_outdoor_experiment(
    config: OutdoorExperiment,
    out_dir: str | os.PathLike[str],
    methods: Methods = (),
    progress: bool = True,
    figures: bool = True,
) -> dict[str, Any]:
    """Run the outdoor protocol; write ``results.json``, ``sfa_model.npz`` and figures. SFA's
    linear regression is also scored on every rotation window (what the fewer windows cost).

    Returns:
        The results, as written to ``results.json``: per method its ``eta_r``, ``eta_phi`` and
        per regression and condition the MAE over ``all`` test frames, the ``unvisited``
        region and the ``visited`` rest (percentages of the ``after`` test run's range).
    """
    out = _output_folder(config, out_dir)
    runs = FolderRuns(out, config, config.world_seed, progress)
    data = outdoor.load_data(config, config.world_seed, runs)
    sfa_method = SlowFeatureMethod(config.sfa, config.rotation, progress=progress)
    found: dict[str, Any] = {}
    for i, (method, regressors) in enumerate([(sfa_method, SFA_REGRESSORS), *methods]):
        scores = outdoor.score_on(config, method, data, regressors, i == 0, progress)
        found[method.name] = scores.entry()
        if i == 0:
            sfa = scores

    drive, n = data.runs["drive"], config.train_frames
    tests = {
        c: _part_summary(data.runs[c], slice(None)) for c in config.test_conditions if c != "after"
    }
    results = _write(
        out,
        sfa.method.model_,
        {
            **results_header("outdoor", config, data.train_pan.shape[2], config.step),
            "eval_windows": data.windows.tolist(),
            "unvisited_region": [float(v) for v in data.region],
            "runs": {
                "train": _part_summary(drive, slice(0, n)),
                "after": _part_summary(drive, slice(n, None)),
                **tests,
            },
            "paper": PAPER_OUTDOOR_RESULTS,
            "methods": found,
        },
    )
    if figures:
        from sfa_gym.cli.figures import trajectory_figures

        every = max(1, len(data.train_pan) // 1500)  # firing maps: 1500 frames are plenty
        after = data.tests["after"]
        trajectory_figures(
            out,
            exclude=data.region,
            model=sfa.method.model_,
            rotation=config.rotation,
            train_run=_Part(drive, slice(0, n)),
            test_run=_Part(drive, slice(n, None)),
            train_pan=data.train_pan[::every],
            train_xy=data.train_xy[::every],
            test_xy=after.xy,
            test_time=after.time,
            estimates=sfa.estimates[FIGURE_REGRESSOR]["after"],
        )
    return results


@dataclass
class _Part:
    """Frames ``part`` of a run, as the trajectory figures read a run."""

    run: Any
    part: slice

    @property
    def poses(self) -> NDArray[np.float64]:
        return self.run.poses[self.part]

    @property
    def metadata(self) -> dict[str, Any]:
        return self.run.metadata

    def __len__(self) -> int:
        return len(self.poses)


def _part_summary(run: Any, part: slice) -> dict[str, Any]:
    xy, time = run.poses[part, :2], run.time[part]
    dynamics = run.metadata["env_kwargs"].get("dynamics")
    return {
        "path": run.path.name,
        "frames": [part.start or 0, (part.start or 0) + len(xy)],
        "run_start_hour": dynamics.get("start_hour") if isinstance(dynamics, dict) else None,
        "start_s": float(time[0]),
        "duration_s": float(time[-1] - time[0]),
        "distance_m": round(float(np.linalg.norm(np.diff(xy, axis=0), axis=1).sum()), 3),
        "end_reason": run.metadata.get("end_reason"),
    }


@dataclass(frozen=True)
class _Protocol:
    out: Path
    """output folder (created); the rendered runs are kept there and reused"""
    baselines: Path | None = None
    """folder of feature-method plug-in files (default: the checkout's baselines/, or those
    shipped with sfa-gym)"""
    no_baselines: bool = False
    """hierarchical SFA only"""
    quiet: bool = False
    """no progress bars"""

    def _evaluate(self, experiment: Callable[..., dict[str, Any]], settings: Any) -> int:
        """Run ``experiment`` with ``settings`` (checked first) and the baselines, each in a
        worker process of its own; write and print the table."""
        settings.validate()
        folder = None if self.no_baselines else self.baselines
        with baseline_workers(self.out, folder, use_default=not self.no_baselines) as found:
            results = experiment(settings, self.out, found, progress=not self.quiet)
        table = format_table(results)
        Path(self.out, "results.txt").write_text(table + "\n")
        print(table)
        print(f"results in {Path(self.out) / 'results.json'}; figures in {self.out}")
        return 0


@dataclass(frozen=True)
class Localize(_Protocol):
    """The paper's simulator localization experiment (grid protocol)."""

    settings: tyro.conf.OmitArgPrefixes[GridExperiment] = GridExperiment()
    """settings of the grid protocol"""

    def run(self) -> int:
        return self._evaluate(run_grid_experiment, self.settings)


@dataclass(frozen=True)
class LocalizeRun(_Protocol):
    """The paper's outdoor protocol: fit on a training run, test on a separate run through a
    region never visited in training."""

    settings: tyro.conf.OmitArgPrefixes[TrajectoryExperiment] = TrajectoryExperiment()
    """settings of the trajectory protocol"""
    no_exclude: bool = False
    """the training run visits everything (same as --exclude None)"""

    def run(self) -> int:
        settings = self.settings
        if self.no_exclude:
            settings = dataclasses.replace(settings, exclude=None)
        return self._evaluate(run_trajectory_experiment, settings)


@dataclass(frozen=True)
class LocalizeOutdoor(_Protocol):
    """The paper's outdoor experiment in the outdoor world (sfa_gym/OmniRoverOutdoor-v0): 5900
    training frames, 2800 test frames right after through a region never visited in training,
    and the appearance tracks (--conditions after later overcast no_movers other_day fog
    rearranged other_season); the sun of a date and place (--day-of-year 15 --latitude-deg 50,
    --seasons for the foliage), several later offsets (--later-hours 2 6), other days
    (--other-days 1 2) and seasons (--season-days 92 183) in one run."""

    settings: tyro.conf.OmitArgPrefixes[OutdoorExperiment] = OutdoorExperiment()
    """settings of the outdoor protocol"""

    def run(self) -> int:
        return self._evaluate(run_outdoor_experiment, self.settings)
