"""Study: why SFA + map decoder lost accuracy on the trajectory protocol since sfa-gym's first
localization release (2026-11-23), while |FFT| + map decoder did not.

Between that release (commit ``60d3351``) and today three things changed that touch these
figures: the camera (the pinhole views look along fixed compass directions and every column is
resampled at its own azimuth, so that a turn by whole columns shifts the panorama exactly; the
release's views turned with the rover: ``PanoramaSpec(views="rover")``), the map decoder (a
bending penalty on the feature maps, chosen by spatial block cross-validation; the release
fitted plain least squares: ``smoothness=0``), and SFA, which is trained again on the new
camera's pixels. The evaluation windows (14 evenly spaced rotation windows) and the SFA
settings are the same in both.

For each world seed this runs today's trajectory protocol (the defaults of ``sfa-gym
localize-run``: train on a lawn-mower run that never enters the south-west corner, test on
loops through it) with both cameras, fits SFA and |FFT| on each camera's training run and
scores each with the map decoder as chosen today (``map``), the map decoder without the
penalty (``map_plain``, the release's) and linear regression, on the test frames in the region
the training covered (``visited``) and in the corner it never entered (``excluded``), MAE in %
of the test run's range. Each cell's mean over the worlds comes with a 95 % t interval
(:mod:`sfa_gym.intervals`). ``--release`` adds the same figures from the release's own code
(``results.json`` of ``sfa-gym localize-run --world-seed S`` run at ``60d3351``, one folder
``<release>/old-S`` per world seed), as read, beside them.

Writes ``published/studies/release_drift.json``; docs/localization.md's table is generated from
it (``sfa-gym docs-tables``).

Usage (from the repository root; renders two runs per world and camera into the render cache)::

    .venv/bin/python -m eval.studies.release_drift --world-seeds 20 21 22 23 24
"""

from __future__ import annotations

import dataclasses
import json
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import tyro
from tqdm.auto import tqdm

from sfa_gym.features import fitted_features
from sfa_gym.files import write_json_atomic
from sfa_gym.intervals import mean_entry
from sfa_gym.localization import fit_predict, mae, make_regressor
from sfa_gym.plugins import load_method_plugin
from sfa_gym.protocols import trajectory
from sfa_gym.protocols.settings import SFASettings
from sfa_gym.protocols.slow_features import SlowFeatureMethod
from sfa_gym.recording.cache import RunCache, RunRequest
from sfa_gym.sim.camera import PanoramaSpec

ROOT = Path(__file__).resolve().parents[2]

CONFIG = trajectory.Config(panorama=(40, 350))
"""``sfa-gym localize-run``'s protocol; the panorama is the env's own (40 x 350), given so that
the release's camera can be asked for at the same size. ``--world`` replaces its world."""

REGRESSIONS: dict[str, dict[str, Any]] = {
    "map": {},  # today's: the bending penalty chosen by block cross-validation
    "map_plain": {"smoothness": 0.0},  # the release's: least squares
    "linear": {},
}
"""Column name -> (make_regressor name, parameters): the name before the first underscore."""

PARTS = ("visited", "excluded")


@dataclass(frozen=True)
class ReleaseCameraRequest(RunRequest):
    """A :class:`RunRequest` rendered with the release's camera (views that turn with the
    rover): the panorama spec says so, and so does the cache key."""

    def panorama_spec(self) -> Any:
        height, width = self.panorama  # type: ignore[misc]
        return PanoramaSpec(width=int(width), height=int(height), views="rover")


class ReleaseCamera:
    """A run source (:class:`~sfa_gym.protocols.RunSource`) that renders every request with the
    release's camera, into the same render cache."""

    def __init__(self, runs: RunCache) -> None:
        self.runs = runs

    def get(self, request: RunRequest) -> Any:
        fields = {f.name: getattr(request, f.name) for f in dataclasses.fields(request)}
        return self.runs.get(ReleaseCameraRequest(**fields))


@dataclass
class Args:
    world_seeds: tuple[int, ...] = (20, 21, 22, 23, 24)
    """world seeds (of paper_sim: none of them a track's or the main job's)"""
    world: str | None = None
    """a world spec (a name in envs/ or a JSON file) to run instead of the env's own
    (paper_sim); the release's code had no such option, so --release needs the default"""
    cameras: tuple[str, ...] = ("compass", "rover")
    """today's camera and the release's"""
    release: Path | None = None
    """folder with ``old-<seed>/results.json`` of the release's ``sfa-gym localize-run``"""
    cache: Path | None = None
    """render cache (None: the default one)"""
    reuse: Path | None = None
    """an earlier file of this study (the same protocol and SFA settings): its worlds are taken
    from it instead of being run again"""
    json: Path = ROOT / "published" / "studies" / "release_drift.json"
    """where to write the figures"""


def method_scores(method: Any, data: trajectory.TrajectoryData) -> dict[str, Any]:
    """MAE % (x, y) of every regression of ``REGRESSIONS`` on each part of the test run."""
    _, f_train, f_test = fitted_features(
        method, data.train_pan, CONFIG.rotation, data.train_pan, data.test_pan, data.windows
    )
    out: dict[str, Any] = {}
    for column, params in REGRESSIONS.items():
        regressor = make_regressor(column.split("_")[0], **params)
        estimates = fit_predict(regressor, f_train, data.train_xy, f_test)
        out[column] = {}
        for part, where in (("visited", ~data.test_inside), ("excluded", data.test_inside)):
            found = mae(estimates[where], data.test_xy[where], coordinate_range=data.test_range)
            out[column][part] = [round(float(v), 4) for v in found.mae_percent]
    return out


def run_world(
    config: trajectory.Config, world_seed: int, camera: str, runs: RunCache
) -> dict[str, Any]:
    """SFA's and |FFT|'s scores on one world with one camera."""
    source = runs if camera == "compass" else ReleaseCamera(runs)
    started = time.perf_counter()
    data = trajectory.load(config, world_seed, source)
    sfa = SlowFeatureMethod(SFASettings(), CONFIG.rotation, progress=False)
    fft = load_method_plugin("fft_magnitude")()
    return {
        "world_seed": world_seed,
        "sfa": method_scores(sfa, data),
        "fft_magnitude": method_scores(fft, data),
        "seconds": round(time.perf_counter() - started, 1),
    }


def release_world(folder: Path) -> dict[str, Any]:
    """The release's figures of one world from its ``results.json`` (``methods`` -> method ->
    regression -> part -> ``mae_percent``; SFA's label was ``hierarchical_sfa``): per method
    (``sfa``, ``fft_magnitude``) and regression (``map``, ``linear``), MAE % per part."""
    found = json.loads((folder / "results.json").read_text())
    out: dict[str, Any] = {}
    for label, method in (("sfa", "hierarchical_sfa"), ("fft_magnitude", "fft_magnitude")):
        entry = found["methods"][method]  # regression -> part -> MAE entry
        out[label] = {
            column: {part: entry[column][part]["mae_percent"] for part in PARTS}
            for column in ("map", "linear")
        }
    return out


def summarise(worlds: list[dict[str, Any]]) -> dict[str, Any]:
    """Mean over the worlds of every method, regression and part, x and y, with a 95 % t
    interval from ``MIN_SEEDS`` worlds on (:func:`~sfa_gym.intervals.mean_entry`)."""
    return {
        label: {
            column: {
                part: [
                    mean_entry(values)
                    for values in np.array([w[label][column][part] for w in worlds]).T
                ]
                for part in PARTS
            }
            for column in worlds[0][label]
        }
        for label in ("sfa", "fft_magnitude")
    }


def _earlier_worlds(
    path: Path | None, config: trajectory.Config
) -> dict[tuple[str, int], dict[str, Any]]:
    """``{(camera, world seed): world}`` of an earlier file of this study, checked to have been
    run with the same protocol and SFA settings."""
    if path is None:
        return {}
    data = json.loads(path.read_text())
    for key, today in (("protocol", config), ("sfa", SFASettings())):
        if data.get(key) != json.loads(json.dumps(dataclasses.asdict(today))):
            raise SystemExit(f"{path}: its {key} settings differ from today's; run it again")
    return {
        (camera, world["world_seed"]): world
        for camera, row in data["rows"].items()
        if camera != "release"
        for world in row["worlds"]
    }


def main(args: Args) -> dict[str, Any]:
    unknown = [c for c in args.cameras if c not in ("compass", "rover")]
    if unknown:
        raise SystemExit(f"unknown cameras {unknown}; expected 'compass' or 'rover'")
    if args.world is not None and args.release is not None:
        raise SystemExit("--release compares the env's own world (the release had no --world)")
    config = dataclasses.replace(CONFIG, world=args.world)
    config.validate()
    runs = RunCache(args.cache)
    earlier = _earlier_worlds(args.reuse, config)
    found: dict[str, list[dict[str, Any]]] = {camera: [] for camera in args.cameras}
    jobs = [(camera, seed) for camera in args.cameras for seed in args.world_seeds]
    for camera, seed in tqdm(jobs, desc="release drift"):
        world = earlier.get((camera, seed)) or run_world(config, seed, camera, runs)
        found[camera].append(world)
    rows = {camera: {"worlds": worlds, **summarise(worlds)} for camera, worlds in found.items()}
    if args.release is not None:
        worlds = [
            {"world_seed": s, **release_world(args.release / f"old-{s}")} for s in args.world_seeds
        ]
        rows["release"] = {"worlds": worlds, **summarise(worlds)}
    result = {
        "format": "sfa-gym-study-release-drift",
        "version": 1,
        "release_commit": "60d3351",
        "protocol": dataclasses.asdict(config),
        "sfa": dataclasses.asdict(SFASettings()),
        "world_seeds": list(args.world_seeds),
        "rows": rows,
    }
    write_json_atomic(args.json, result)
    print(f"wrote {args.json}")
    return result


if __name__ == "__main__":
    main(tyro.cli(Args))
