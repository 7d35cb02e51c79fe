"""Plug-ins in worker processes (sfa_gym.sandbox): an honest plug-in gives the features it gives
in-process; a hostile one sees none of the evaluator's objects, cannot write outside its scratch
folder (under bubblewrap), is stopped at its time limit or reported when it dies; a controller
sees only its observation and the rover's own sensors."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import sfa_gym  # noqa: F401  (registers the envs)
from sfa_gym.navigation.field import FeatureField
from sfa_gym.navigation.sensors import ROVER_SENSORS, Rover
from sfa_gym.plugins import PluginError, load_method, load_method_plugin
from sfa_gym.sandbox import (
    InProcess,
    IsolatedController,
    IsolatedMethod,
    Limits,
    PluginCrashed,
    PluginTimeout,
    confinement,
)

ROOT = Path(__file__).resolve().parents[1]
BAND_MEANS = ROOT / "baselines" / "band_means.py"

HEADER = """
from dataclasses import dataclass
import numpy as np

@dataclass(frozen=True)
class Args:
    target: str = ""

class Method:
    name = "hostile"
    def __init__(self, target=""):
        self.target = target
    def fit(self, views, sequence_ids=None):
        self.input_shape_ = views.shape[1:]
        return self
    def transform(self, views):
        return np.repeat(np.asarray([self.look()], dtype=np.float64), len(views), axis=0)
"""


def _plugin(tmp_path: Path, text: str, name: str = "hostile.py") -> Path:
    path = tmp_path / name
    path.write_text(HEADER + text + "\nMETHOD = Method\n")
    return path


def _views(n: int = 6) -> np.ndarray:
    return np.random.default_rng(0).integers(0, 256, (n, 8, 24, 3), dtype=np.uint8)


@pytest.fixture
def outside(tmp_path):
    """``baselines/band_means.py`` copied out of the package: a file from outside, in a worker."""
    path = tmp_path / "band_means.py"
    path.write_bytes(BAND_MEANS.read_bytes())
    return path


def test_an_honest_plugin_gives_the_same_features_isolated(outside):
    views = _views(40)
    inside = load_method(BAND_MEANS, {"n_bands": 4}).fit(views)  # built-in: in process
    assert isinstance(inside, InProcess)
    with load_method(outside, {"n_bands": 4}) as isolated:
        assert isinstance(isolated, IsolatedMethod)
        assert isolated.name == inside.name
        assert isolated.capabilities == inside.capabilities
        assert isolated.get_params() == inside.get_params()
        assert isolated.fit(views) is isolated and isolated.input_shape_ == inside.input_shape_
        features = isolated.transform(views)
    expected = inside.transform(views)
    assert features.dtype == expected.dtype and np.array_equal(features, expected)


SPY = """
    def look(self):
        import gc, sys
        frames, names, frame = 0, set(), sys._getframe()
        while frame is not None:
            frames += frame.f_globals.get("__name__", "").startswith(("tests", "test_"))
            names |= set(frame.f_locals)
            frame = frame.f_back
        secrets = sum(type(o).__name__ == "EvaluatorSecret" for o in gc.get_objects())
        envs = sum("OmniRover" in type(o).__name__ for o in gc.get_objects())
        return [frames, "secret_positions" in names, secrets, envs]
"""


class EvaluatorSecret:
    """Ground truth an evaluator holds while it calls a plug-in."""


def test_a_plugin_sees_none_of_the_evaluators_objects(tmp_path):
    secret_positions = EvaluatorSecret()  # noqa: F841  (in this frame, where a spy would look)
    env = gym.make("sfa_gym/OmniRover-v0")
    try:
        with load_method(_plugin(tmp_path, SPY)) as method:
            found = method.fit(_views()).transform(_views())
    finally:
        env.close()
    frames, saw_name, secrets, envs = found[0]
    assert (frames, saw_name, secrets, envs) == (0, 0, 0, 0)
    # the same plug-in in-process finds them all: the test can fail
    inside = load_method_plugin(_plugin(tmp_path, SPY, "inside.py"))().fit(_views())
    frames, saw_name, secrets, envs = inside.transform(_views())[0]
    assert frames >= 1 and saw_name and secrets == 1 and envs >= 1


WRITER = """
    def look(self):
        import os, subprocess
        from pathlib import Path
        subprocess.run(["mount", "-o", "remount,rw", "/"], capture_output=True)  # as root
        try:
            Path(self.target, "written.txt").write_text("forged")
            outside = 1.0
        except OSError:
            outside = 0.0
        Path("scratch.txt").write_text("mine")  # its own folder is writable
        return [outside, float(os.path.exists(Path(self.target, "hidden", "poses.npy")))]
"""


def test_a_confined_plugin_cannot_write_outside_or_read_hidden_folders(tmp_path):
    if confinement() is None:
        pytest.skip("no working bubblewrap here: plug-ins run unconfined (see sfa_gym.sandbox)")
    outside = tmp_path / "results"
    (outside / "hidden").mkdir(parents=True)
    (outside / "hidden" / "poses.npy").write_bytes(b"ground truth")
    path = _plugin(tmp_path, WRITER)
    with load_method(path, {"target": str(outside)}, hidden=[outside / "hidden"]) as method:
        wrote, saw = method.fit(_views()).transform(_views())[0]
    assert (wrote, saw) == (0.0, 0.0)
    assert not (outside / "written.txt").exists()


def test_a_plugin_that_hangs_is_stopped_at_its_limit(tmp_path):
    sleeper = "    def look(self):\n        return [0.0]\n" + (
        "    def fit(self, views, sequence_ids=None):\n        import time; time.sleep(600)\n"
    )
    method = load_method(_plugin(tmp_path, sleeper), limits=Limits(fit=2.0))
    with pytest.raises(PluginTimeout, match=r"hostile\.py took longer than its limit of 2 s"):
        method.fit(_views())
    with pytest.raises(PluginCrashed, match="already stopped"):
        method.transform(_views())


def test_a_plugin_that_dies_is_reported_with_its_exit_code(tmp_path):
    dying = "    def look(self):\n        import os; os._exit(3)\n"
    with load_method(_plugin(tmp_path, dying)) as method:
        method.fit(_views())
        with pytest.raises(PluginCrashed, match=r"hostile\.py's worker died with exit code 3"):
            method.transform(_views())


def test_wrong_outputs_and_arguments_are_refused_naming_the_plugin(tmp_path, outside):
    words = "    def transform(self, views):\n        return [['go']] * len(views)\n"
    with load_method(_plugin(tmp_path, words)) as method:
        with pytest.raises(PluginError, match="hostile: transform"):
            method.fit(_views()).transform(_views())
    for source in (BAND_MEANS, outside):  # in process, then in a worker
        with pytest.raises(ValueError, match="unknown argument 'n_band'") as raised:
            load_method(source, {"n_band": 3})
    assert "in the worker process of the plug-in" in raised.value.__notes__[0]  # its traceback
    with pytest.raises(ValueError, match="time limit act"):
        Limits(act=0)


CONTROLLER = """
from dataclasses import dataclass
import gc
import numpy as np

@dataclass(frozen=True)
class Args:
    speed: float = 0.2

class Spy:
    name = "spy"
    def reset(self, obs, info):
        self.seen = sorted(info)
    def act(self, obs, info):
        envs = sum("OmniRover" in type(o).__name__ for o in gc.get_objects())
        cheated = self.seen != sorted(info) or envs > 0 or "x" in info
        return np.array([float(cheated), float(len(self.seen)), -1.0], dtype=np.float32)

def make_controller(rover, weights, speed=0.2):
    return Spy()
"""


def test_a_controller_never_receives_ground_truth(tmp_path):
    path = tmp_path / "spy.py"
    path.write_text(CONTROLLER)
    xs = np.linspace(-3.0, 3.0, 13)
    gx, gy = np.meshgrid(xs, xs)
    field = FeatureField(np.stack([gx, gy], axis=-1), (-3.0, 3.0, -3.0, 3.0))
    env = gym.make("sfa_gym/OmniRoverNav-v0", feature_field=field)
    try:
        obs, info = env.reset(seed=3)
        assert {"x", "y", "goal"} <= set(info)  # the env knows the pose ...
        with IsolatedController(path, Rover.of(env), [1.0, 1.0]) as controller:
            controller.reset(obs, info)
            action = controller.act(obs, info)  # ... the controller does not
    finally:
        env.close()
    assert action.dtype == np.float32
    assert action.tolist() == [0.0, float(len(ROVER_SENSORS)), -1.0]


def test_a_leaderboard_task_runs_its_method_isolated_with_its_time_limits(tmp_path):
    from test_leaderboard import TINY, _write_track, band_means_fitting

    from sfa_gym.leaderboard.evaluate import Task, run_task

    track = str(_write_track(tmp_path / "tracks", TINY))
    slow = band_means_fitting(tmp_path / "slow.py", "import time\ntime.sleep(600)")
    cache = str(tmp_path / "cache")
    with pytest.raises(PluginTimeout, match=r"slow\.py took longer than its limit of 2 s for fit"):
        run_task(Task(track, str(slow), {}, 100, cache_dir=cache, time_limits={"fit": 2}))
    with pytest.raises(ValueError, match="no time limit named 'fitt'"):
        run_task(Task(track, str(BAND_MEANS), {}, 100, cache_dir=cache, time_limits={"fitt": 1}))


@pytest.mark.parametrize(
    ("features", "message"),
    [
        ("np.ones((3, len(views)))", r"must have shape \(6, k\) with k >= 1, got \(3, 6\)"),
        ("np.ones((len(views) - 1, 3))", r"must have shape \(6, k\) with k >= 1, got \(5, 3\)"),
        ("np.ones(len(views))", r"must have shape \(6, k\) with k >= 1, got \(6,\)"),
        ("np.full((len(views), 3), np.nan)", "non-finite features"),
        ("np.full((len(views), 3), 1e300)", "magnitude 1e\\+300; expected at most 1e\\+12"),
        (
            "np.ones((len(views), 3)) * 1j",
            "must be an array of real numbers, got an array of complex",
        ),
    ],
)
def test_wrong_features_are_refused_naming_the_plugin(tmp_path, features, message):
    text = f"""
    def look(self):
        return 0.0
    def transform(self, views):
        return {features}
"""
    with load_method(_plugin(tmp_path, text), {}) as isolated:
        isolated.fit(_views())
        with pytest.raises(PluginError, match=f"hostile: transform\\(views\\).*{message}"):
            isolated.transform(_views())


@pytest.mark.parametrize(
    ("where", "value", "message"),
    [
        ((0, 0), np.nan, "non-finite features"),
        ((4, 2), np.inf, "non-finite features"),
        ((5, 1), -np.inf, "non-finite features"),
        ((2, 2), -3e12, "magnitude 3e\\+12; expected at most 1e\\+12"),
        ((1, 0), 2e12, "magnitude 2e\\+12; expected at most 1e\\+12"),
    ],
)
def test_one_bad_feature_among_good_ones_is_found(where, value, message):
    """The checks look at every value: one bad number anywhere, of either sign, is refused."""
    from sfa_gym.sandbox.proxies import checked_features

    features = np.random.default_rng(0).uniform(-1e12, 1e12, (6, 3))
    assert checked_features(features, (6,), "p", "transform") is features
    features[where] = value
    with pytest.raises(PluginError, match=f"p: transform returned .*{message}"):
        checked_features(features, (6,), "p", "transform")
    integers = np.full((6, 3), 10**12, dtype=np.int64)
    assert checked_features(integers, (6,), "p", "transform") is integers
    integers[where] = -(10**12) - 1
    with pytest.raises(PluginError, match="magnitude 1e\\+12; expected at most"):
        checked_features(integers, (6,), "p", "transform")


def test_each_plugin_gets_a_worker_of_its_own_started_ahead(outside):
    from sfa_gym.sandbox import process

    with load_method(outside) as first:
        (spare,) = [p.pid for p, _ in process._spare.values()]
        assert spare != first._worker.process.pid
    with load_method(outside) as second:
        # the spare serves the next plug-in: no plug-in code ran in it before
        assert second._worker.process.pid == spare
        assert second.fit(_views()).transform(_views()).shape == (6, 8 * 3)
    assert first._worker.process is None  # killed when closed, not reused


RECORDER = """
    def fit(self, views, sequence_ids=None):
        views = np.asarray(views)
        self.seen = {"shape": "x".join(map(str, views.shape)), "digest": __import__(
            "hashlib").sha256(np.ascontiguousarray(views).tobytes()).hexdigest()}
        return self
    def get_params(self, deep=True):
        return getattr(self, "seen", {})
    def look(self):
        return [0.0]
"""


@pytest.mark.parametrize(("appearances", "indices"), [(1, None), (2, [0, 3, 5])])
def test_an_isolated_method_is_fitted_on_exactly_the_training_views(tmp_path, appearances, indices):
    import hashlib

    from sfa_gym.features import fit_on_views, training_views
    from sfa_gym.rotation import Rotation

    panoramas = np.random.default_rng(1).integers(0, 256, (6, 8, 24, 3), dtype=np.uint8)
    rotation, picked = Rotation(step=4, window=12), None if indices is None else np.array(indices)
    views = training_views(panoramas, rotation, appearances, picked)
    with load_method(_plugin(tmp_path, RECORDER)) as isolated:
        fit_on_views(isolated, panoramas, rotation, appearances, picked)
        seen = isolated.get_params()
    assert seen["shape"] == "x".join(map(str, views.shape))
    assert seen["digest"] == hashlib.sha256(views.tobytes()).hexdigest()


def test_rotation_averages_are_the_same_in_process_and_in_a_worker(tmp_path):
    """The package's raw pixels in process (its fast path, every rotation at once) and the same
    file from outside in a worker (``transform`` of every rotated view): the same averages."""
    from sfa_gym.features import rotation_averaged_features

    raw_pixels, args = ROOT / "baselines" / "raw_pixels.py", {"height": 2, "width": 6}
    outside = tmp_path / "raw_pixels.py"
    outside.write_bytes(raw_pixels.read_bytes())
    panoramas = np.random.default_rng(2).integers(0, 256, (5, 8, 24, 3), dtype=np.uint8)
    inside = load_method(raw_pixels, args).fit(panoramas)
    assert isinstance(inside, InProcess) and callable(inside.transform_rotations)
    expected = rotation_averaged_features(inside, panoramas, step=1)
    with load_method(outside, args) as isolated:
        assert not hasattr(isolated, "transform_rotations")  # not part of the contract
        got = rotation_averaged_features(isolated.fit(panoramas), panoramas, step=1)
    assert got.dtype == np.float64 and np.array_equal(got, expected)
