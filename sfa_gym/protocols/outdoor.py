"""The outdoor protocol: the paper's outdoor experiment in the outdoor world and its appearance
tracks, one feature method at a time.

The paper's section 3.2 (Metka, Franzius & Bauer-Wersing 2013) in ``sfa_gym/OmniRoverOutdoor-v0``
(the ``paper_outdoor`` world through the mirror camera, the sun moving over the day, clouds,
movers, auto-exposure and pixel noise, the camera on a sprung mast): one drive of
``train_frames`` on a joystick-like grid that never enters a 1.5 x 1.5 m square in the
south-west, then, without stopping the clock, ``test_frames`` that cross it
(:class:`~sfa_gym.recording.outdoor_path.OutdoorPathDriver`, ``part="both"``). Appearance
tracks (``conditions``) record the test path again under one change each, holding the others:
``later`` (``later_hours`` later), ``overcast``, ``no_movers``, ``other_day`` (``other_days``
later: other clouds and mover schedules); ``after`` (the drive's test part, the paper's
protocol) is always scored. Several ``later_hours`` or ``other_days`` give one condition each;
the sun can be dated (``day_of_year``, ``latitude_deg``) and the day chosen (``day``): the
settings and the env of each run are in :mod:`sfa_gym.protocols.outdoor_settings`.

Fitting (:func:`fit_outdoor`): hierarchical SFA (its ``fit_rotations``) on every
simulated rotation of every training frame in time order; a column statistic
(``rotation_invariant``) once per panorama; any other on the evaluated rotation windows of every
``fit_every``-th training frame (all views of 5900 panoramas 60 x 600 would be 76 GB). Each
regression is fitted on the ``eval_rotations`` windows of every training frame, and a test
frame's estimate is the mean over its windows. Scores: MAE in m and in % of the ``after`` test
run's coordinate range, over all test frames, in the unvisited region and in the visited rest.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sfa_gym.features import (
    fit_method,
    fit_on_views,
    fits_on_panoramas,
    invariance_entry,
    view_features,
)
from sfa_gym.localization.appearance import normalise_panoramas
from sfa_gym.phases import phase
from sfa_gym.plugins import FeatureMethod, get_capabilities

# the settings live in their own module; their public names are re-exported here
from sfa_gym.protocols.outdoor_settings import CONDITIONS, ENV_ID, Condition, Config
from sfa_gym.rotation import spread_indices

__all__ = [
    "CONDITIONS",
    "ENV_ID",
    "Condition",
    "Config",
    "OutdoorData",
    "Scores",
    "condition_scores",
    "covered_scores",
    "covers",
    "fit_outdoor",
    "interleave",
    "load_data",
    "requests",
    "score",
    "score_on",
]


def _request(env_kwargs: dict[str, Any], driver: Any, seed: int) -> Any:
    import gymnasium as gym

    from sfa_gym.recording.cache import RunRequest, env_defaults

    kwargs = dict(env_kwargs)
    # world seed and panorama are fields of the request (the cache passes them on)
    world_seed = kwargs.pop("world_seed")
    panorama = kwargs.pop("panorama", None) or env_defaults(ENV_ID)["panorama"]
    if isinstance(panorama, str):  # the env's own camera, by its preset's name
        from sfa_gym.sim.camera import PanoramaSpec

        panorama = getattr(PanoramaSpec, panorama)()
    return RunRequest(
        world=gym.spec(ENV_ID).kwargs["world"],
        world_seed=world_seed,
        panorama=(panorama.height, panorama.width),
        driver=driver,
        seed=seed,
        env_id=ENV_ID,
        env_kwargs=kwargs,
    )


def requests(config: Config, world_seed: int) -> dict[str, Any]:
    """The runs of one world seed, by name: ``"drive"`` (training and ``after`` frames), one
    per other test condition (:attr:`Config.test_conditions`), and ``"train_<hours>h"`` per
    hour of ``train_also``."""
    drive = config.env_kwargs("after", world_seed)
    out = {"drive": _request(drive, config.driver("both"), config.seed)}
    for condition in config.test_conditions:
        if condition != "after":
            kwargs = config.env_kwargs(condition, world_seed)
            out[condition] = _request(kwargs, config.driver("test"), config.seed)
    for hours in config.train_also:
        kwargs = config.env_kwargs("after", world_seed)
        hour = (config.start_hour + hours) % 24.0  # train_also needs dynamics (checked)
        kwargs["dynamics"] = dataclasses.replace(kwargs["dynamics"], start_hour=hour)
        out[f"train_{hours:+g}h"] = _request(kwargs, config.driver("train"), config.seed)
    return out


@dataclass
class TestSet:
    """The test frames of one condition: panoramas, positions, times and the in-region mask."""

    panoramas: Any
    xy: NDArray[np.float64]
    time: NDArray[np.float64]
    inside: NDArray[np.bool_]


def interleave(arrays: Sequence[NDArray[Any]]) -> NDArray[Any]:
    """Frame 0 of every array, then frame 1 of every array, ...: ``R`` arrays ``(n, ...)`` ->
    ``(n * R, ...)``."""
    stacked = np.stack(arrays, axis=1)
    return stacked.reshape(-1, *stacked.shape[2:])


@dataclass
class OutdoorData:
    """The runs of one world seed, read once for every method scored on them.

    Attributes:
        runs: the runs by name (see :func:`requests`).
        requests: the requests they were asked for, by name.
        region: the unvisited south-west rectangle ``(xmin, xmax, ymin, ymax)``.
        tests: the test frames by condition (``"after"`` first), normalised.
        train_pan, train_xy: the training panoramas (normalised, ``train_also`` runs
            interleaved) and their positions.
        windows: the evaluated rotation windows.
    """

    runs: dict[str, Any]
    requests: dict[str, Any]
    region: tuple[float, ...]
    tests: dict[str, TestSet]
    train_pan: NDArray[np.uint8]
    train_xy: NDArray[np.float64]
    windows: NDArray[np.intp]

    @property
    def test_range(self) -> NDArray[np.float64]:
        """The coordinate range of the ``after`` test run: the MAE's 100 %."""
        xy = self.tests["after"].xy
        return xy.max(axis=0) - xy.min(axis=0)


def load_data(config: Config, world_seed: int, runs: Any) -> OutdoorData:
    """Read (``runs.get``, rendering what is missing) and cut the runs of ``world_seed``."""
    from sfa_gym.geometry import in_rectangle
    from sfa_gym.recording.outdoor_path import south_west

    config.validate()
    asked = requests(config, world_seed)
    with phase("render"):
        got = {name: runs.get(request) for name, request in asked.items()}
    drive, n = got["drive"], config.train_frames
    if len(drive) != n + config.test_frames:
        raise ValueError(
            f"the drive has {len(drive)} frames, expected {n} + {config.test_frames}: "
            f"it ended early ({drive.metadata.get('end_reason')})"
        )
    region = tuple(south_west(drive.metadata["arena_bounds"]))
    tests = {}
    for condition in dict.fromkeys(("after", *config.test_conditions)):
        run = got.get(condition)
        if run is None:
            panoramas, poses, time = drive.panoramas[n:], drive.poses[n:], drive.time[n:]
        else:
            panoramas, poses, time = run.panoramas[:], run.poses, run.time
        xy = np.asarray(poses[:, :2], dtype=np.float64)
        panoramas = normalise_panoramas(np.asarray(panoramas), config.normalise)
        tests[condition] = TestSet(panoramas, xy, time, in_rectangle(xy, region))
    panoramas = [np.asarray(drive.panoramas[:n])]
    positions = [np.asarray(drive.positions[:n], dtype=np.float64)]
    for hours in config.train_also:
        run = got[f"train_{hours:+g}h"]
        panoramas.append(np.asarray(run.panoramas[:]))
        positions.append(np.asarray(run.positions, dtype=np.float64))
    train_pan = panoramas[0] if len(panoramas) == 1 else interleave(panoramas)
    train_xy = positions[0] if len(positions) == 1 else interleave(positions)
    train_pan = normalise_panoramas(train_pan, config.normalise)
    windows = spread_indices(config.rotation.n_views(train_pan.shape[2]), config.eval_rotations)
    return OutdoorData(got, asked, region, tests, train_pan, train_xy, windows)


def condition_scores(estimates: NDArray, test: TestSet, test_range: NDArray) -> dict[str, Any]:
    """MAE of ``estimates (M, 2)`` over ``all`` test frames, the ``unvisited`` region and the
    ``visited`` rest, in m and in % of ``test_range``."""
    from sfa_gym.localization import mae
    from sfa_gym.localization.metrics import mae_dict

    entry: dict[str, Any] = {"all": mae_dict(mae(estimates, test.xy, coordinate_range=test_range))}
    for part, where in (("unvisited", test.inside), ("visited", ~test.inside)):
        entry[part] = (
            mae_dict(mae(estimates[where], test.xy[where], coordinate_range=test_range))
            if where.any()
            else None
        )
    return entry


def fit_outdoor(method: FeatureMethod, config: Config, data: OutdoorData) -> FeatureMethod:
    """``method`` fitted on the training frames (see the module docstring)."""
    rotation, train_pan, runs = config.rotation, data.train_pan, config.appearances
    if fits_on_panoramas(method, rotation, train_pan):
        return fit_method(method, train_pan, rotation, runs)
    # every fit_every-th frame, with its train_also runs where they share its rotations
    places = np.arange(0, len(train_pan) // runs, config.fit_every)
    frames = (places[:, None] * runs + np.arange(runs)).ravel()
    return fit_on_views(method, train_pan[frames], rotation, runs, data.windows)


@dataclass
class Scores:
    """What scoring one method found.

    Attributes:
        method: the fitted method.
        regressions: per regression, per condition, the MAE over ``all`` test frames, the
            ``unvisited`` region and the ``visited`` rest (:func:`condition_scores`).
        estimates: per regression, per condition, the estimates ``(M, 2)`` (m).
        invariance: ``eta_r``, ``eta_phi`` and ``n_features`` of the training features.
        all_windows: with ``all_windows=True``: the linear regression's ``after`` scores with
            every rotation window (what the fewer windows cost), else None.
        data: the runs it was scored on.
    """

    method: FeatureMethod
    regressions: dict[str, dict[str, Any]]
    estimates: dict[str, dict[str, NDArray[np.float64]]]
    invariance: dict[str, Any]
    data: OutdoorData
    all_windows: dict[str, Any] | None = None
    conditions: tuple[str, ...] = field(default=("after",))

    def entry(self) -> dict[str, Any]:
        """The method's entry of ``results.json``: invariance, then one entry per regression
        (and ``all_windows``)."""
        out = {**self.invariance, **self.regressions}
        if self.all_windows is not None:
            out["all_windows"] = {"linear": {"after": self.all_windows}}
        return out

    def task_scores(self) -> dict[str, Any]:
        """A leaderboard task's scores, of the first regression (JSON types): ``score`` (the
        mean over ``conditions`` of the all-frames MAE %), ``parts`` (per scored condition, and
        ``unvisited``: the ``after`` run inside the south-west region), ``conditions``,
        ``regressor``, ``n_features``, ``frames`` and the cache keys of the runs."""
        regressor, found = next(iter(self.regressions.items()))
        data = self.data
        frames = {
            "train": len(data.runs["drive"]) - len(data.tests["after"].xy),
            "test": len(data.tests["after"].xy),
            "unvisited": int(data.tests["after"].inside.sum()),
            "windows": len(data.windows),
        }
        renders = {name: request.key() for name, request in data.requests.items()}
        n_features = int(self.invariance["n_features"])
        return _task_scores(found, self.conditions, regressor, n_features, frames, renders)


def _task_scores(
    found: Mapping[str, Any],
    conditions: Sequence[str],
    regressor: str,
    n_features: int,
    frames: dict[str, int],
    renders: dict[str, str],
) -> dict[str, Any]:
    """:meth:`Scores.task_scores` from each condition's entry ``found`` (``"after"`` first)."""

    def percent(entry: Mapping[str, Any] | None) -> float | None:
        return None if entry is None else float(np.mean(entry["mae_percent"]))

    parts: dict[str, float | None] = {c: percent(e["all"]) for c, e in found.items()}
    parts["unvisited"] = percent(found["after"]["unvisited"])
    return {
        "score": float(np.mean([parts[c] for c in conditions])),
        "parts": parts,
        "conditions": dict(found),
        "regressor": regressor,
        "n_features": n_features,
        "frames": frames,
        "renders": renders,
    }


def covers(config: Config, other: Config) -> bool:
    """Whether a task scored with ``config`` gives the scores of ``other`` too: the same settings
    but for ``conditions``, and ``other``'s test conditions among ``config``'s. The fit, the
    regression and each condition's estimates do not depend on which other conditions are
    scored, so ``other``'s scores are a part of ``config``'s (:func:`covered_scores`): one
    task serves the paper's track and the appearance tracks of a world seed."""
    if replace(config, conditions=other.conditions) != other:
        return False
    # "after" (the drive's own test part) is scored by every task
    return set(other.test_conditions) <= {"after", *config.test_conditions}


def covered_scores(scores: Mapping[str, Any], other: Config, world_seed: int) -> dict[str, Any]:
    """The task scores (:meth:`Scores.task_scores`) of ``other`` on ``world_seed``, from the
    task scores ``scores`` of a config that :func:`covers` it on the same world seed.

    Raises:
        ValueError: ``scores`` lack a run or a condition of ``other``'s, or rendered a run
            that ``other`` asks for differently.
    """
    asked = {name: request.key() for name, request in requests(other, world_seed).items()}
    renders = scores["renders"]
    wanted = dict.fromkeys(("after", *other.test_conditions))
    for name, key in asked.items():
        if renders.get(name) != key:
            raise ValueError(
                f"the covering task rendered run {name!r} as {renders.get(name)!r}, "
                f"this config asks for {key!r}"
            )
    missing = [c for c in wanted if c not in scores["conditions"]]
    if missing:
        raise ValueError(f"the covering task did not score conditions {missing}")
    found = {c: scores["conditions"][c] for c in wanted}
    frames, n_features = dict(scores["frames"]), int(scores["n_features"])
    return _task_scores(
        found, other.test_conditions, scores["regressor"], n_features, frames, asked
    )


def score_on(
    config: Config,
    method: FeatureMethod,
    data: OutdoorData,
    regressors: Sequence[str] | None = None,
    all_windows: bool = False,
    progress: bool = False,
) -> Scores:
    """Fit ``method`` on ``data`` and score each of ``regressors`` (default: the method's
    ``regressor``, else linear) under every condition; ``all_windows``: also the linear
    regression on every rotation window (cheap for a method with ``transform_rotations``,
    :mod:`sfa_gym.features`)."""
    from sfa_gym.localization import fit_predict, make_regressor, predict_locations

    if regressors is None:
        regressors = (get_capabilities(method).regressor,)
    rotation, windows, name = config.rotation, data.windows, method.name
    fitted = fit_outdoor(method, config, data)
    # all windows of the training and "after" frames for the all-windows entry; the evaluated
    # ones are picked from them (the rotation shortcut computes every window anyway)
    every = None if all_windows else windows
    f_train = view_features(fitted, data.train_pan, rotation, every, f"{name} train", progress)
    f_tests = {
        c: view_features(fitted, t.panoramas, rotation, every, f"{name} {c}", progress)
        for c, t in data.tests.items()
    }
    whole = None
    if all_windows:
        found = fit_predict(make_regressor("linear"), f_train, data.train_xy, f_tests["after"])
        whole = condition_scores(found, data.tests["after"], data.test_range)
        f_train = f_train[:, windows]
        f_tests = {c: f[:, windows] for c, f in f_tests.items()}
    n_views = f_train.shape[1]
    regressions: dict[str, dict[str, Any]] = {}
    estimates: dict[str, dict[str, NDArray[np.float64]]] = {}
    for reg in dict.fromkeys(regressors):
        regressor = make_regressor(reg)
        # every window of a training frame is a sample labelled with the frame's position
        labels = np.repeat(data.train_xy, n_views, 0)
        regressor.fit(f_train.reshape(-1, f_train.shape[2]), labels)
        regressions[reg], estimates[reg] = {}, {}
        for c, test in data.tests.items():
            estimates[reg][c] = predict_locations(regressor, f_tests[c])
            regressions[reg][c] = condition_scores(estimates[reg][c], test, data.test_range)
    return Scores(
        method=fitted,
        regressions=regressions,
        estimates=estimates,
        invariance=invariance_entry(f_train),
        data=data,
        all_windows=whole,
        conditions=config.test_conditions,
    )


def score(
    config: Config,
    method: FeatureMethod,
    world_seed: int,
    runs: Any,
    *,
    regressors: Sequence[str] | None = None,
    progress: bool = False,
) -> Scores:
    """Fit ``method`` on the training frames of ``world_seed`` and score each of ``regressors``
    (default: the method's own ``regressor``) under every condition; ``runs`` gives the runs
    (:class:`~sfa_gym.protocols.RunSource`). Writes no files."""
    data = load_data(config, world_seed, runs)
    return score_on(config, method, data, regressors, progress=progress)
