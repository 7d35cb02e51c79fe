"""The paper's outdoor experiment in the outdoor world, and its appearance tracks.

:func:`run_outdoor_experiment` follows section 3.2 of Metka, Franzius & Bauer-Wersing (2013) in
``sfa_gym/OmniRoverOutdoor-v0`` (the ``paper_outdoor`` world through the mirror camera, the sun
moving over the day, clouds, pedestrians, a cyclist and cars, auto-exposure and pixel noise, the
camera on a sprung mast): the rover drives a joystick-like grid for 5900 frames that never
enters a 1.5 x 1.5 m square in the south-west, then, without stopping the clock, 2800 test frames
that cross it (:class:`~sfa_gym.recording.outdoor_path.OutdoorPathDriver`, ``part="both"``).
Hierarchical SFA is fitted on all 120 simulated rotations (5 px steps of 600) of every training
frame, in time order; each method's regression is fitted on the training run and scored on the
test run, overall and inside the region never visited in training, with the MAE in metres and
in % of the test run's coordinate range, as the paper reports it.

Appearance tracks (``conditions``): the same test path recorded again under one change each,
scored with the models fitted on the training run:

- ``after``: the paper's protocol, the test run right after training (always scored);
- ``later``: ``later_hours`` later in the day (the sun elsewhere, another light);
- ``overcast``: a grey sky against the training run's sunny one;
- ``no_movers``: without the pedestrians, cyclist and cars;
- ``other_day``: another day (other clouds, other mover schedules).

Every change holds the others: each test run starts at the time of day the ``after`` part does
(``later`` excepted) with the same seed.

Cost: hierarchical SFA trains on every rotation; column statistics (band means, |FFT|) are
the same for every full-width rotation and see each panorama once; the other plug-ins are
fitted on the evaluated windows of every ``fit_every``-th training frame, which bounds their
memory (all views of 5900 panoramas 60 x 600 would be 76 GB). Estimates are averaged over
``eval_rotations`` evenly spread windows per frame for every method alike; the results also
give SFA's error with all 120 windows, to show what the fewer windows cost.
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal, get_args

import numpy as np
from numpy.typing import NDArray

from sfa_gym._checks import check_int, check_positive_int, is_number
from sfa_gym.experiments.common import FIGURE_REGRESSOR, methods_with_sfa
from sfa_gym.experiments.report import check_out_folder, mae_dict, results_header, write_results
from sfa_gym.experiments.trajectory import PAPER_OUTDOOR_RESULTS
from sfa_gym.geometry import in_rectangle
from sfa_gym.localization import fit_predict, mae, make_regressor, predict_locations
from sfa_gym.localization.appearance import Normalisation, normalise_panoramas
from sfa_gym.plugins import FeatureMethod, get_capabilities
from sfa_gym.protocols.features import fit_method, full_width, invariance_entry, view_features
from sfa_gym.protocols.settings import SFASettings, check_choice
from sfa_gym.rotation import Rotation, check_step, spread_indices

__all__ = [
    "CONDITIONS",
    "OutdoorExperiment",
    "condition_scores",
    "interleave",
    "run_outdoor_experiment",
    "test_sets",
]

ENV_ID = "sfa_gym/OmniRoverOutdoor-v0"
Condition = Literal["after", "later", "overcast", "no_movers", "other_day"]
CONDITIONS: tuple[str, ...] = get_args(Condition)
"""The test conditions (see the module docstring)."""
Camera = Literal["mirror", "cylindrical"]


@dataclass(frozen=True)
class OutdoorExperiment:
    """Settings of the outdoor protocol (defaults: the paper's)."""

    world_seed: int = 0
    """seed of the world's procedural variation (scenery, clouds, movers)"""
    panorama: tuple[int, int] | None = None
    """(height, width) of the panoramas in pixels (quick runs); None: the paper's 60 x 600"""
    train_frames: int = 5900
    """frames of the training run (the paper: 5900)"""
    test_frames: int = 2800
    """frames of the test run (the paper: 2800)"""
    frame_dt: float = 0.1
    """seconds between frames (the env's control period); longer periods give short test
    runs over the same paths"""
    spacing: float = 0.5
    """training run: distance between the grid's lanes, m (larger for short runs)"""
    test_spacing: float = 1.0
    """test run: distance between the grid's lanes, m"""
    start_hour: float = 10.0
    """time of day at which the training run starts, hours"""
    conditions: tuple[Condition, ...] = ("after",)
    """test conditions scored (appearance tracks): after, later, overcast, no_movers,
    other_day"""
    later_hours: float = 4.0
    """the "later" test run starts this many hours after the "after" one"""
    dynamics: bool = True
    """the world's dynamics (sun, clouds, movers); False: a static world (ablation)"""
    sensor: bool = True
    """the camera's auto-exposure and pixel noise"""
    vibration: bool = True
    """the sprung camera mast (False: a rigid one)"""
    camera: Camera = "mirror"
    """the mirror camera (unwarped) or the ideal cylindrical one"""
    step: int = 5
    """simulated rotation step, columns (must divide the panorama width)"""
    eval_rotations: int | None = 12
    """evenly spread rotation windows per frame (12: every 30 degrees) whose features every
    regression is fitted on and averages over; None: all (120 at 600 px: slow for plug-ins
    that transform every view; SFA's estimate over all 120 is reported beside)"""
    normalise: Normalisation = "none"
    """input normalisation of every panorama, for every method (sfa_gym.localization.appearance:
    none, grey_world, log_gradient)"""
    train_also: tuple[float, ...] = ()
    """levers: the training path driven again, starting this many hours after start_hour, each
    such run interleaved frame by frame with the training run (the appearance of a place then
    changes faster than the place); every method trains on all of them"""
    fit_every: int = 5
    """plug-ins without a rotation shortcut are fitted on every n-th training frame"""
    sfa: SFASettings = SFASettings(network="paper_outdoor")
    """the hierarchical SFA network"""
    seed: int = 0
    """seed of the env resets (sensor noise) and of the path planner"""

    @property
    def rotation(self) -> Rotation:
        """The simulated rotation every method is trained and evaluated on."""
        return Rotation(step=self.step)

    def validate(self) -> None:
        """Raise ValueError (or TypeError) naming the first bad setting."""
        for name in ("world_seed", "seed"):
            check_int(name, getattr(self, name))
        for name in ("train_frames", "test_frames"):
            if check_positive_int(name, getattr(self, name)) < 10:
                raise ValueError(f"{name} must be >= 10, got {getattr(self, name)!r}")
        for name in ("step", "fit_every"):
            check_positive_int(name, getattr(self, name))
        if self.eval_rotations is not None:
            check_positive_int("eval_rotations", self.eval_rotations)
        for name in ("frame_dt", "spacing", "test_spacing"):
            value = getattr(self, name)
            if not is_number(value) or not math.isfinite(value) or value <= 0:
                raise ValueError(f"{name} must be a positive number of metres, got {value!r}")
        for name in ("start_hour", "later_hours"):
            value = getattr(self, name)
            if not is_number(value) or not math.isfinite(value):
                raise ValueError(f"{name} must be a finite number of hours, got {value!r}")
        if not 0.0 <= self.start_hour < 24.0:
            raise ValueError(f"start_hour must lie in [0, 24) hours, got {self.start_hour!r}")
        if not isinstance(self.conditions, tuple | list) or not self.conditions:
            raise ValueError(f"conditions must be a non-empty tuple, got {self.conditions!r}")
        for condition in self.conditions:
            check_choice("conditions", condition, Condition)
        if not self.dynamics and set(self.conditions) - {"after"}:
            raise ValueError(
                f"conditions {sorted(set(self.conditions) - {'after'})} change the dynamics; "
                "they need dynamics=True"
            )
        for name in ("dynamics", "sensor", "vibration"):
            if not isinstance(getattr(self, name), bool):
                raise TypeError(f"{name} must be True or False, got {getattr(self, name)!r}")
        check_choice("camera", self.camera, Camera)
        check_choice("normalise", self.normalise, Normalisation)
        if not isinstance(self.train_also, tuple | list) or not all(
            is_number(h) and math.isfinite(h) and h != 0 for h in self.train_also
        ):
            raise ValueError(
                f"train_also must be a tuple of non-zero hours, got {self.train_also!r}"
            )
        if self.train_also and not self.dynamics:
            raise ValueError("train_also drives at other times of day: it needs dynamics=True")
        if self.panorama is not None:
            if not isinstance(self.panorama, tuple | list) or len(self.panorama) != 2:
                raise ValueError(
                    f"panorama must be None or (height, width) in pixels, got {self.panorama!r}"
                )
            for value in self.panorama:
                check_positive_int("panorama", value)
        check_step(600 if self.panorama is None else self.panorama[1], self.step)
        self.sfa.validate()

    def driver(self, part: Literal["train", "test", "both"]) -> Any:
        """The driver of the whole drive (``"both"``) or of one of its paths."""
        from sfa_gym.recording.outdoor_path import OutdoorPathDriver

        return OutdoorPathDriver(
            part,
            train_frames=self.train_frames,
            test_frames=self.test_frames,
            spacing=self.spacing,
            test_spacing=self.test_spacing,
        )

    def env_kwargs(self, condition: Condition) -> dict[str, Any]:
        """Keyword arguments of ``gym.make(ENV_ID)`` for the drive (``"after"``: the whole
        drive, starting at ``start_hour``) or for the test run under ``condition``."""
        kwargs: dict[str, Any] = {
            "world_seed": self.world_seed,
            "control_dt": self.frame_dt,
            "camera": self.camera,
            "sensor": self.sensor,
            "rover": "outdoor" if self.vibration else "default",
        }
        if self.camera == "cylindrical":
            kwargs["mirror"] = None
        if self.panorama is not None:
            from sfa_gym.sim.camera import PanoramaSpec

            height, width = self.panorama
            kwargs["panorama"] = PanoramaSpec(width=int(width), height=int(height))
        if not self.dynamics:
            return {**kwargs, "dynamics": False}
        if condition == "after":
            return {**kwargs, "start_hour": self.start_hour}
        # the test runs start when the "after" part does: the training run's frames later
        hour = (self.start_hour + (self.train_frames * self.frame_dt) / 3600.0) % 24.0
        if condition == "later":
            return {**kwargs, "start_hour": (hour + self.later_hours) % 24.0}
        if condition == "no_movers":
            return {**kwargs, "start_hour": hour, "movers": False}
        from sfa_gym.sim.worlds import load_world_spec

        declared = load_world_spec("paper_outdoor").dynamics
        change = {"overcast": {"overcast": 1.0}, "other_day": {"day": declared.day + 1}}
        spec = dataclasses.replace(declared, **change[condition])
        return {**kwargs, "start_hour": hour, "dynamics": spec}


@dataclass
class _TestSet:
    """The test frames of one condition: panoramas, positions, times and the in-region mask."""

    panoramas: Any
    xy: NDArray[np.float64]
    time: NDArray[np.float64]
    inside: NDArray[np.bool_]


def _record(config: OutdoorExperiment, out: Path, progress: bool) -> tuple[Any, dict[str, Any]]:
    """Record (or resume) the drive and the test runs of the conditions; returns the drive and
    the test runs by condition (``"after"``: None, it is the drive's second part)."""
    from sfa_gym.recording.recorder import record

    drive = record(
        ENV_ID,
        config.driver("both"),
        out / "drive.run",
        seed=config.seed,
        env_kwargs=config.env_kwargs("after"),
        progress=progress,
    )
    tests: dict[str, Any] = {"after": None}
    for condition in config.conditions:
        if condition != "after":
            tests[condition] = record(
                ENV_ID,
                config.driver("test"),
                out / f"test_{condition}.run",
                seed=config.seed,
                env_kwargs=config.env_kwargs(condition),
                progress=progress,
            )
    return drive, tests


def _training_set(
    config: OutdoorExperiment, drive: Any, out: Path, progress: bool
) -> tuple[NDArray[np.uint8], NDArray[np.float64]]:
    """Training panoramas and positions: the drive's first part, interleaved frame by frame
    with the training path driven again at the hours of ``config.train_also``."""
    from sfa_gym.recording.recorder import record

    n = config.train_frames
    panoramas = [np.asarray(drive.panoramas[:n])]
    positions = [np.asarray(drive.positions[:n], dtype=np.float64)]
    for hours in config.train_also:
        kwargs = config.env_kwargs("after")
        kwargs["start_hour"] = (config.start_hour + hours) % 24.0
        run = record(
            ENV_ID,
            config.driver("train"),
            out / f"train_{hours:+g}h.run",
            seed=config.seed,
            env_kwargs=kwargs,
            progress=progress,
        )
        panoramas.append(np.asarray(run.panoramas[:]))
        positions.append(np.asarray(run.positions, dtype=np.float64))
    if len(panoramas) == 1:
        return panoramas[0], positions[0]
    return interleave(panoramas), interleave(positions)


def interleave(arrays: Sequence[NDArray[Any]]) -> NDArray[Any]:
    """Frame 0 of every array, then frame 1 of every array, ...: ``R`` arrays ``(n, ...)`` ->
    ``(n * R, ...)``."""
    stacked = np.stack(arrays, axis=1)
    return stacked.reshape(-1, *stacked.shape[2:])


def test_sets(
    config: OutdoorExperiment, drive: Any, runs: dict[str, Any], region: Sequence[float]
) -> dict[str, _TestSet]:
    """The test frames of each condition (``"after"``: the drive's frames after training),
    normalised as ``config`` says, with their positions and the frames inside ``region``."""
    n = config.train_frames
    if len(drive) != n + config.test_frames:
        raise ValueError(
            f"the drive has {len(drive)} frames, expected {n} + {config.test_frames}: "
            f"it ended early ({drive.metadata.get('end_reason')})"
        )
    sets = {}
    for condition, run in runs.items():
        if run is None:
            panoramas, poses, time = drive.panoramas[n:], drive.poses[n:], drive.time[n:]
        else:
            panoramas, poses, time = run.panoramas[:], run.poses, run.time
        xy = np.asarray(poses[:, :2], dtype=np.float64)
        panoramas = normalise_panoramas(np.asarray(panoramas), config.normalise)
        sets[condition] = _TestSet(panoramas, xy, time, in_rectangle(xy, region))
    return sets


def condition_scores(estimates: NDArray, test: _TestSet, test_range: NDArray) -> dict[str, Any]:
    """MAE of ``estimates (M, 2)`` over ``all`` test frames, the ``unvisited`` region and the
    ``visited`` rest, in m and in % of ``test_range``."""
    entry: dict[str, Any] = {"all": mae_dict(mae(estimates, test.xy, coordinate_range=test_range))}
    for part, where in (("unvisited", test.inside), ("visited", ~test.inside)):
        entry[part] = (
            mae_dict(mae(estimates[where], test.xy[where], coordinate_range=test_range))
            if where.any()
            else None
        )
    return entry


def run_outdoor_experiment(
    config: OutdoorExperiment,
    out_dir: str | os.PathLike[str],
    methods: Sequence[tuple[FeatureMethod, Sequence[str]]] = (),
    progress: bool = True,
    figures: bool = True,
) -> dict[str, Any]:
    """Run the outdoor protocol; write ``results.json``, ``sfa_model.npz`` and figures.

    Args:
        config: the protocol's settings.
        out_dir: output folder (created); the runs are kept there (``drive.run``,
            ``test_<condition>.run``) and reused or resumed by the next call.
        methods: extra feature methods with their regressions (plug-ins); hierarchical SFA
            comes first, with the paper's linear regression, a quadratic one and the map
            decoder.
        progress: progress bars.
        figures: write the PNG figures (trajectories, estimates, error map, firing maps).

    Returns:
        The results, as written to ``results.json``: per method its ``eta_r``, ``eta_phi`` and
        per regression and condition the MAE over ``all`` test frames, the ``unvisited``
        region and the ``visited`` rest (percentages of the ``after`` test run's range).
    """
    from sfa_gym.recording.outdoor_path import south_west
    from sfa_gym.sfa.io import save_model

    config.validate()
    out = Path(out_dir)
    check_out_folder(out)
    out.mkdir(parents=True, exist_ok=True)
    drive, runs = _record(config, out, progress)
    region = south_west(drive.metadata["arena_bounds"])
    tests = test_sets(config, drive, runs, region)
    n = config.train_frames
    train_pan, train_xy = _training_set(config, drive, out, progress)
    train_pan = normalise_panoramas(train_pan, config.normalise)
    after = tests["after"]
    test_range = after.xy.max(axis=0) - after.xy.min(axis=0)
    rotation = config.rotation
    width = train_pan.shape[2]
    windows = spread_indices(rotation.n_views(width), config.eval_rotations)
    fit_frames = np.arange(0, len(train_pan), config.fit_every)

    found: dict[str, Any] = {}
    sfa_estimates: dict[str, NDArray[np.float64]] = {}
    evaluated = methods_with_sfa(config.sfa, rotation, methods, progress)
    for i, (method, regressors) in enumerate(evaluated):
        if i == 0:  # hierarchical SFA: every rotation of every training frame, in time order
            fitted = fit_method(method, train_pan, rotation)
        elif get_capabilities(method).rotation_invariant and full_width(rotation, train_pan):
            fitted = fit_method(method, train_pan, rotation)  # once per panorama
        else:  # the evaluated windows of every fit_every-th frame (memory, see above)
            views = rotation.views(train_pan[fit_frames], windows)[0]
            fitted = method.fit(views.reshape(-1, *views.shape[2:]))
            del views
        name = method.name
        # SFA's rotation shortcut yields every window at once: keep all of the training and
        # "after" frames for the all-windows entry and pick the evaluated ones from them
        every = None if i == 0 else windows
        f_train = view_features(fitted, train_pan, rotation, every, f"{name} train", progress)
        f_tests = {
            c: view_features(fitted, t.panoramas, rotation, every, f"{name} {c}", progress)
            for c, t in tests.items()
        }
        if i == 0:
            all_train, all_after = f_train, f_tests["after"]
            f_train = f_train[:, windows]
            f_tests = {c: f[:, windows] for c, f in f_tests.items()}
        entry = invariance_entry(f_train)
        n_views = f_train.shape[1]
        for reg in dict.fromkeys(regressors):
            regressor = make_regressor(reg)
            # every view of a training frame is a sample labelled with the frame's position
            regressor.fit(f_train.reshape(-1, f_train.shape[2]), np.repeat(train_xy, n_views, 0))
            entry[reg] = {}
            for c, t in tests.items():
                estimates = predict_locations(regressor, f_tests[c])
                entry[reg][c] = condition_scores(estimates, t, test_range)
                if i == 0 and reg == FIGURE_REGRESSOR:
                    sfa_estimates[c] = estimates
        found[name] = entry
        if i == 0:
            estimates = fit_predict(make_regressor("linear"), all_train, train_xy, all_after)
            found[name]["all_windows"] = {
                "linear": {"after": condition_scores(estimates, after, test_range)}
            }

    results: dict[str, Any] = {
        **results_header("outdoor", config, width, config.step),
        "eval_windows": windows.tolist(),
        "unvisited_region": [float(v) for v in region],
        "runs": {
            "train": _run_summary(drive, slice(0, n)),
            "after": _run_summary(drive, slice(n, None)),
            **{c: _run_summary(r, slice(None)) for c, r in runs.items() if r is not None},
        },
        "paper": PAPER_OUTDOOR_RESULTS,
        "methods": found,
    }
    model = evaluated[0][0].model_
    save_model(model, out / "sfa_model.npz")
    results = write_results(out / "results.json", results)
    if figures:
        from sfa_gym.experiments.figures import trajectory_figures

        every = max(1, len(train_pan) // 1500)  # firing maps: 1500 frames are plenty
        trajectory_figures(
            out,
            exclude=region,
            model=model,
            rotation=rotation,
            train_run=_Part(drive, slice(0, n)),
            test_run=_Part(drive, slice(n, None)),
            train_pan=train_pan[::every],
            train_xy=train_xy[::every],
            test_xy=after.xy,
            test_time=after.time,
            estimates=sfa_estimates["after"],
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


def _run_summary(run: Any, part: slice) -> dict[str, Any]:
    xy, time = run.poses[part, :2], run.time[part]
    return {
        "path": run.path.name,
        "frames": [part.start or 0, (part.start or 0) + len(xy)],
        "run_start_hour": run.metadata["env_kwargs"].get("start_hour"),
        "start_s": float(time[0]),
        "duration_s": float(time[-1] - time[0]),
        "distance_m": round(float(np.linalg.norm(np.diff(xy, axis=0), axis=1).sum()), 3),
        "end_reason": run.metadata.get("end_reason"),
    }
