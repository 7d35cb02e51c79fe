"""Recorded runs: record/load roundtrip, interrupted recordings resume exactly, damaged files."""

from __future__ import annotations

import json
import math
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

from sfa_gym.recording import runfile
from sfa_gym.recording.drivers import GridPositions, LawnMowerDriver, LoopDriver, RandomWalkDriver
from sfa_gym.recording.recorder import ReplayMismatchError, RunMismatchError, record
from sfa_gym.recording.runfile import RunFormatError, load_run


class TinyRover(gym.Env):
    """A 2 m x 2 m arena, unicycle with first-order velocity lag, 4x24 synthetic panoramas.

    Column c looks at azimuth yaw + 2*pi*c/W; its colour encodes the distance to the wall in
    that direction, so panoramas depend on position and rotate with yaw like the real env's.
    """

    metadata = {"render_modes": []}
    arena_bounds = (-1.0, 1.0, -1.0, 1.0)
    dt = 0.1

    def __init__(self, lag: float = 0.5) -> None:
        self.lag = lag
        self.observation_space = gym.spaces.Box(0, 255, (4, 24, 3), np.uint8)
        self.action_space = gym.spaces.Box(
            np.array([-0.4, -1.0], np.float32), np.array([0.4, 1.0], np.float32)
        )

    def grid_positions(self, n: int = 30) -> np.ndarray:
        g = np.linspace(-0.8, 0.8, n)
        gx, gy = np.meshgrid(g, g)
        return np.stack([gx.ravel(), gy.ravel()], axis=1)

    def _obs(self) -> np.ndarray:
        az = self.yaw + 2 * np.pi * np.arange(24) / 24
        c, s = np.cos(az), np.sin(az)
        with np.errstate(divide="ignore"):
            tx = np.where(c > 0, (1 - self.x) / c, np.where(c < 0, (-1 - self.x) / c, np.inf))
            ty = np.where(s > 0, (1 - self.y) / s, np.where(s < 0, (-1 - self.y) / s, np.inf))
        d = np.minimum(tx, ty)
        rows = np.arange(4)[:, None]
        red = np.clip(d * 100, 0, 255)[None, :] + 0 * rows
        green = np.clip(128 + 60 * np.sign(c), 0, 255)[None, :] + 10 * rows
        blue = np.full((4, 24), 40.0) + self.noise
        return np.stack([red, green, blue], axis=-1).astype(np.uint8)

    def _info(self) -> dict:
        return {"x": self.x, "y": self.y, "yaw": self.yaw}

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        pose = (options or {}).get("pose", (0.0, 0.0, 0.0))
        self.x, self.y, self.yaw = (float(p) for p in pose)
        self.v = self.w = 0.0
        self.noise = float(self.np_random.integers(0, 10))  # seeded randomness, as a real env has
        return self._obs(), self._info()

    def step(self, action):
        v, w = np.clip(action, self.action_space.low, self.action_space.high)
        self.v += (float(v) - self.v) * self.lag
        self.w += (float(w) - self.w) * self.lag
        self.x = float(np.clip(self.x + self.v * math.cos(self.yaw) * self.dt, -1, 1))
        self.y = float(np.clip(self.y + self.v * math.sin(self.yaw) * self.dt, -1, 1))
        self.yaw = (self.yaw + self.w * self.dt + math.pi) % (2 * math.pi) - math.pi
        return self._obs(), 0.0, False, False, self._info()


def _mower() -> LawnMowerDriver:
    return LawnMowerDriver(spacing=0.4, margin=0.3, pattern="rows", spin=math.pi)


def _rollout(env: gym.Env, driver, n: int, seed: int):
    """The samples record() must store, computed independently of it."""
    driver.reset(env.get_wrapper_attr("arena_bounds"), dt=env.get_wrapper_attr("dt"), seed=seed)
    obs, info = env.reset(seed=seed, options={"pose": driver.start_pose})
    frames, poses, actions = [obs], [(info["x"], info["y"], info["yaw"])], [np.zeros(2)]
    while len(frames) < n and not driver.done:
        action = driver(info)
        obs, _, _, _, info = env.step(action)
        frames.append(obs)
        poses.append((info["x"], info["y"], info["yaw"]))
        actions.append(action)
    return np.array(frames), np.array(poses), np.array(actions, dtype=np.float32)


def _assert_same_run(a, b) -> None:
    np.testing.assert_array_equal(np.asarray(a.panoramas), np.asarray(b.panoramas))
    for name in ("poses", "time", "actions"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
        assert getattr(a, name).dtype == getattr(b, name).dtype


class Interrupt(Exception):
    pass


def _stop_after(n_samples: int):
    def on_chunk(n: int) -> None:
        if n >= n_samples:
            raise KeyboardInterrupt

    return on_chunk


# ------------------------------------------------------------------------ roundtrip


def test_record_load_roundtrip_equals_an_independent_rollout(tmp_path):
    run = record(
        TinyRover(), _mower(), tmp_path / "a.run", n_steps=23, chunk_size=5, seed=3,
        progress=False,
    )  # fmt: skip
    frames, poses, actions = _rollout(TinyRover(), _mower(), 23, seed=3)
    loaded = load_run(tmp_path / "a.run")
    for r in (run, loaded):
        assert len(r) == 23 and r.complete and r.metadata["end_reason"] == "n_steps"
        np.testing.assert_array_equal(np.asarray(r.panoramas), frames)
        np.testing.assert_array_equal(r.poses, poses)
        np.testing.assert_array_equal(r.actions, actions)
        np.testing.assert_allclose(r.time, np.arange(23) * 0.1)
        assert r.panoramas.shape == (23, 4, 24, 3) and r.panoramas.dtype == np.uint8
        assert r.poses.dtype == np.float64 and r.actions.dtype == np.float32
    header = json.loads((tmp_path / "a.run" / "run.json").read_text())
    assert header["format"] == "sfa-gym-run" and header["version"] == 2 and header["n"] == 23
    assert header["driver"]["type"] == "LawnMowerDriver" and header["seed"] == 3
    # no temporaries left behind; the arrays are plain .npy files without pickles
    assert sorted(p.name for p in (tmp_path / "a.run").iterdir()) == [
        "actions.npy", "panoramas.npy", "poses.npy", "run.json", "time.npy",
    ]  # fmt: skip
    np.testing.assert_array_equal(np.load(tmp_path / "a.run" / "panoramas.npy"), frames)
    np.testing.assert_array_equal(np.load(tmp_path / "a.run" / "poses.npy"), poses)


def test_panoramas_index_like_an_array(tmp_path, monkeypatch):
    monkeypatch.setattr(runfile, "BLOCK_BYTES", 4 * 24 * 3 * 5)  # mapped 5 samples at a time
    run = record(
        TinyRover(), _mower(), tmp_path / "a.run", n_steps=17, chunk_size=4, progress=False
    )
    full = np.asarray(run.panoramas)
    p = run.panoramas
    np.testing.assert_array_equal(p[5], full[5])
    np.testing.assert_array_equal(p[-1], full[-1])
    np.testing.assert_array_equal(p[3:14:3], full[3:14:3])
    np.testing.assert_array_equal(p[[16, 0, 7, 7]], full[[16, 0, 7, 7]])
    mask = np.arange(17) % 3 == 0
    np.testing.assert_array_equal(p[mask], full[mask])
    np.testing.assert_array_equal(p[2:9, 1, :5], full[2:9, 1, :5])
    np.testing.assert_array_equal(np.stack(list(p)), full)
    with pytest.raises(IndexError, match="17"):
        p[17]


def test_driver_done_ends_the_run(tmp_path):
    driver = LawnMowerDriver(spacing=1.0, margin=0.5, pattern="rows")
    run = record(TinyRover(), driver, tmp_path / "d.run", chunk_size=50, progress=False)
    assert run.complete and run.metadata["end_reason"] == "driver_done" and driver.done
    assert 20 < len(run) < 1000


# --------------------------------------------------------------------------- resume


@pytest.mark.parametrize(("stop_at", "stored"), [(5, 5), (10, 10), (10, 5)])
def test_interrupted_recording_resumes_to_the_same_arrays(tmp_path, stop_at, stored):
    reference = record(
        TinyRover(), _mower(), tmp_path / "ref.run", n_steps=23, chunk_size=5, seed=1,
        progress=False,
    )  # fmt: skip
    out = tmp_path / "cut.run"
    with pytest.raises(KeyboardInterrupt):
        record(
            TinyRover(), _mower(), out, n_steps=23, chunk_size=5, seed=1, progress=False,
            on_chunk=_stop_after(stop_at),
        )  # fmt: skip
    header = json.loads((out / "run.json").read_text())
    # stored < stop_at: interrupted after a block's arrays were written, before its header
    (out / "run.json").write_text(json.dumps({**header, "n": stored}))
    partial = load_run(out)
    assert not partial.complete and len(partial) == stored
    # a fresh env and driver: the state is rebuilt by replaying the stored actions
    resumed = record(TinyRover(), _mower(), out, n_steps=23, chunk_size=5, seed=1, progress=False)
    assert resumed.complete
    _assert_same_run(resumed, reference)


def test_interrupt_between_chunks_keeps_the_buffered_samples(tmp_path):
    env = TinyRover()
    steps = []

    def failing_step(action):
        if len(steps) == 7:
            raise Interrupt  # e.g. the renderer dies in the middle of a chunk
        steps.append(action)
        return TinyRover.step(env, action)

    env.step = failing_step
    driver = RandomWalkDriver(speed=0.3, margin=0.3)
    with pytest.raises(Interrupt):
        record(env, driver, tmp_path / "r.run", n_steps=20, chunk_size=5, progress=False)
    assert len(load_run(tmp_path / "r.run")) == 8  # reset + 7 steps, the last 3 flushed
    resumed = record(
        TinyRover(), RandomWalkDriver(speed=0.3, margin=0.3), tmp_path / "r.run", n_steps=20,
        chunk_size=5, progress=False,
    )  # fmt: skip
    reference = record(
        TinyRover(), RandomWalkDriver(speed=0.3, margin=0.3), tmp_path / "ref.run", n_steps=20,
        chunk_size=5, progress=False,
    )  # fmt: skip
    _assert_same_run(resumed, reference)


def test_pose_list_run_resumes_to_the_same_arrays(tmp_path):
    grid = GridPositions(n=4, seed=2, order="hilbert")
    reference = record(TinyRover(), grid, tmp_path / "ref.run", chunk_size=3, progress=False)
    assert len(reference) == 16 and reference.metadata["kind"] == "poses"
    np.testing.assert_allclose(reference.poses, grid.poses(TinyRover()))
    np.testing.assert_array_equal(reference.actions, 0)
    with pytest.raises(KeyboardInterrupt):
        record(
            TinyRover(), grid, tmp_path / "cut.run", chunk_size=3, progress=False,
            on_chunk=_stop_after(6),
        )  # fmt: skip
    resumed = record(TinyRover(), grid, tmp_path / "cut.run", chunk_size=3, progress=False)
    _assert_same_run(resumed, reference)


def test_complete_run_is_returned_not_rerecorded(tmp_path):
    first = record(TinyRover(), _mower(), tmp_path / "a.run", n_steps=6, progress=False)
    mtime = (tmp_path / "a.run" / "panoramas.npy").stat().st_mtime_ns
    again = record(TinyRover(), _mower(), tmp_path / "a.run", n_steps=6, progress=False)
    _assert_same_run(first, again)
    assert (tmp_path / "a.run" / "panoramas.npy").stat().st_mtime_ns == mtime


def test_resume_with_other_settings_is_refused(tmp_path):
    out = tmp_path / "a.run"
    with pytest.raises(KeyboardInterrupt):
        record(
            TinyRover(), _mower(), out, n_steps=20, chunk_size=5, seed=0, progress=False,
            on_chunk=_stop_after(5),
        )  # fmt: skip
    with pytest.raises(RunMismatchError, match=r"seed: stored 0, requested 1"):
        record(TinyRover(), _mower(), out, n_steps=20, chunk_size=5, seed=1, progress=False)
    with pytest.raises(RunMismatchError, match="spacing"):
        record(
            TinyRover(), LawnMowerDriver(spacing=0.5, margin=0.3, pattern="rows", spin=math.pi),
            out, n_steps=20, chunk_size=5, progress=False,
        )  # fmt: skip
    # overwrite starts afresh
    run = record(TinyRover(), _mower(), out, n_steps=8, seed=1, overwrite=True, progress=False)
    assert run.complete and len(run) == 8 and run.metadata["seed"] == 1


def test_resume_detects_non_deterministic_physics(tmp_path):
    out = tmp_path / "a.run"
    with pytest.raises(KeyboardInterrupt):
        record(
            TinyRover(), _mower(), out, n_steps=20, chunk_size=5, progress=False,
            on_chunk=_stop_after(10),
        )  # fmt: skip
    # the same settings as far as the header can tell, but other dynamics
    with pytest.raises(ReplayMismatchError, match="not deterministic"):
        record(TinyRover(lag=0.3), _mower(), out, n_steps=20, chunk_size=5, progress=False)


def test_bad_arguments_are_refused(tmp_path):
    with pytest.raises(ValueError, match=r"'<name>\.run'"):
        record(TinyRover(), _mower(), tmp_path / "a", n_steps=5, progress=False)
    with pytest.raises(ValueError, match="never finishes"):
        record(TinyRover(), RandomWalkDriver(), tmp_path / "a.run", progress=False)
    with pytest.raises(ValueError, match="chunk_size"):
        record(TinyRover(), _mower(), tmp_path / "a.run", n_steps=5, chunk_size=0)
    with pytest.raises(TypeError, match="driver"):
        record(TinyRover(), object(), tmp_path / "a.run", n_steps=5)


# ------------------------------------------------------------------ damaged files


def _mapped_files() -> set[str]:
    return {line.split(maxsplit=5)[-1] for line in Path("/proc/self/maps").read_text().splitlines()}


@pytest.fixture
def small_run(tmp_path):
    record(TinyRover(), _mower(), tmp_path / "a.run", n_steps=12, chunk_size=5, progress=False)
    return tmp_path / "a.run"


@pytest.mark.skipif(not Path("/proc/self/maps").is_file(), reason="reads Linux's /proc/self/maps")
def test_reading_panoramas_leaves_nothing_mapped(small_run, monkeypatch):
    """A map left open keeps every page read resident beside the copies made of them."""
    monkeypatch.setattr(runfile, "BLOCK_BYTES", 4 * 24 * 3 * 5)  # mapped 5 samples at a time
    run = load_run(small_run)
    file = str((small_run / "panoramas.npy").resolve())
    kept = [run.panoramas[[0, 4, 11]], run.panoramas[2:10], np.asarray(run.panoramas)]
    kept.append(next(iter(run.panoramas)).copy())
    assert file not in _mapped_files()
    row = next(iter(run.panoramas))  # held by the caller: mapped while it is held
    assert file in _mapped_files()
    del row
    assert file not in _mapped_files()
    np.testing.assert_array_equal(kept[0][1], kept[1][2])


def _truncate(path: Path) -> None:
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])


@pytest.mark.parametrize(
    ("damage", "message"),
    [
        (_truncate, r"panoramas\.npy is damaged, truncated or foreign"),
        (Path.unlink, r"panoramas\.npy is missing"),
        (lambda p: np.save(p, np.array([{}]), allow_pickle=True), "Python objects"),
        (lambda p: np.save(p, np.zeros((12, 4, 24), np.uint8)), r"shape \(12, 4, 24\)"),
        (lambda p: np.save(p, np.zeros((11, 4, 24, 3), np.uint8)), r"run\.json says 12"),
    ],
)
def test_a_damaged_array_file_is_named(small_run, damage, message):
    damage(small_run / "panoramas.npy")
    with pytest.raises(RunFormatError, match=message):
        load_run(small_run)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ('{"format": "other-tool", "version": 1}', "not a 'sfa-gym-run' header"),
        ("[1, 2, 3]", "not a 'sfa-gym-run' header"),
        ("{not json", "not valid JSON"),
        ('{"format": "sfa-gym-run", "version": 1}', "format version 1.*reads version 2"),
        ('{"format": "sfa-gym-run", "version": 2, "shape": [4, 24, 3]}', "lacks a valid 'shape'"),
    ],
)
def test_foreign_header_is_named(small_run, text, message):
    (small_run / "run.json").write_text(text)
    with pytest.raises(RunFormatError, match=rf"run\.json.*{message}|{message}.*run\.json"):
        load_run(small_run)


def test_missing_header_and_directory(tmp_path, small_run):
    shutil.copytree(small_run, tmp_path / "copy.run")
    (tmp_path / "copy.run" / "run.json").unlink()
    with pytest.raises(RunFormatError, match="run.json is missing"):
        load_run(tmp_path / "copy.run")
    with pytest.raises(FileNotFoundError, match="nothing.run"):
        load_run(tmp_path / "nothing.run")


# ------------------------------------------------------------------- the real env

ENV_ID = "sfa_gym/OmniRover-v0"


def _real_mower() -> LawnMowerDriver:
    return LawnMowerDriver(spacing=1.0, pattern="rows")


def test_real_env_run_resumes_to_the_same_arrays(tmp_path):
    import sfa_gym  # noqa: F401  (registers the envs)

    settings = dict(n_steps=12, chunk_size=5, seed=2, progress=False)
    reference = record(ENV_ID, _real_mower(), tmp_path / "ref.run", **settings)
    with pytest.raises(KeyboardInterrupt):
        record(ENV_ID, _real_mower(), tmp_path / "cut.run", on_chunk=_stop_after(5), **settings)
    resumed = record(ENV_ID, _real_mower(), tmp_path / "cut.run", **settings)
    _assert_same_run(resumed, reference)
    meta = reference.metadata
    assert meta["env_id"] == ENV_ID and meta["world"] == "paper_sim" and meta["world_seed"] == 0
    assert meta["panorama"]["width"] == 350 and meta["shape"] == [40, 350, 3]
    # what shaped the pixels: the camera, the mirror (none here) and the rover with its mast
    assert meta["camera"] == "cylindrical" and meta["mirror"] is None
    assert meta["rover"]["type"] == "RoverSpec" and meta["rover"]["mast_stiffness"] is None
    assert meta["dt"] == 0.1 and len(meta["arena_bounds"]) == 4
    np.testing.assert_allclose(reference.time, np.arange(12) * 0.1, atol=1e-9)
    assert reference.panoramas[11].std() > 10  # a rendered scene, not a blank image
    # the rover moved along the first row
    assert reference.poses[-1, 0] - reference.poses[0, 0] > 0.2


def test_real_env_pose_list_run(tmp_path):
    import sfa_gym  # noqa: F401

    grid = GridPositions(n=2, seed=0)
    run = record(ENV_ID, grid, tmp_path / "grid.run", chunk_size=3, progress=False)
    env = gym.make(ENV_ID)
    expected = grid.poses(env)
    obs, _ = env.reset(seed=0, options={"pose": tuple(expected[1])})
    env.close()
    assert len(run) == 4 and run.metadata["end_reason"] == "driver_done"
    np.testing.assert_allclose(run.poses[:, :2], expected[:, :2], atol=1e-6)
    np.testing.assert_allclose(
        np.angle(np.exp(1j * (run.poses[:, 2] - expected[:, 2]))), 0, atol=1e-6
    )
    np.testing.assert_array_equal(run.panoramas[1], obs)


def test_resuming_a_damaged_run_is_refused(tmp_path):
    out = tmp_path / "a.run"
    with pytest.raises(KeyboardInterrupt):
        record(
            TinyRover(), _mower(), out, n_steps=20, chunk_size=5, progress=False,
            on_chunk=_stop_after(10),
        )  # fmt: skip
    _truncate(out / "poses.npy")
    with pytest.raises(RunFormatError, match=r"poses\.npy is damaged"):
        record(TinyRover(), _mower(), out, n_steps=20, chunk_size=5, progress=False)


# ------------------------------------------------- nothing is written before the checks


@pytest.mark.parametrize(
    "driver, message",
    [
        (LawnMowerDriver(spacing=-1.0), "spacing"),
        (LawnMowerDriver(spin=math.nan), "spin"),
        (LoopDriver(insets=(5.0,)), "inset"),
        (GridPositions(n=0), "n must"),
    ],
)
def test_bad_driver_options_are_refused_before_anything_is_written(tmp_path, driver, message):
    out = tmp_path / "a.run"
    with pytest.raises(ValueError, match=message):
        record(TinyRover(), driver, out, n_steps=5, progress=False)
    assert not out.exists()
    assert record(TinyRover(), _mower(), out, n_steps=5, progress=False).complete


def test_non_finite_settings_never_reach_the_header(tmp_path):
    env = TinyRover()
    env.world_seed = math.nan
    out = tmp_path / "a.run"
    with pytest.raises(ValueError, match=r"non-finite.*world_seed = nan"):
        record(env, _mower(), out, n_steps=5, progress=False)
    assert not out.exists()


class _FloatImages(TinyRover):
    def __init__(self) -> None:
        super().__init__()
        self.observation_space = gym.spaces.Box(0.0, 1.0, (4, 24, 3), np.float32)


class _NoArena(TinyRover):
    arena_bounds = None


@pytest.mark.parametrize(
    "env, message",
    [(_FloatImages(), r"uint8 Box of shape \(H, W, 3\)"), (_NoArena(), "arena_bounds")],
)
def test_unsuitable_envs_are_refused_before_anything_is_written(tmp_path, env, message):
    out = tmp_path / "a.run"
    with pytest.raises(ValueError, match=message):
        record(env, _mower(), out, n_steps=5, progress=False)
    assert not out.exists()


def test_bad_output_paths_and_seeds_are_refused_in_one_line(tmp_path):
    (tmp_path / "file.run").write_text("")
    with pytest.raises(ValueError, match=r"file\.run' exists and is not a directory"):
        record(TinyRover(), _mower(), tmp_path / "file.run", n_steps=5, progress=False)
    (tmp_path / "plain").write_text("")
    with pytest.raises(ValueError, match="is a file"):
        record(TinyRover(), _mower(), tmp_path / "plain" / "a.run", n_steps=5, progress=False)
    for seed in (-1, True, 1.5):
        with pytest.raises(ValueError, match="seed"):
            record(TinyRover(), _mower(), tmp_path / "a.run", n_steps=5, seed=seed)
    with pytest.raises(ValueError, match="n_steps"):
        record(TinyRover(), _mower(), tmp_path / "a.run", n_steps=True)
    assert not (tmp_path / "a.run").exists()


class _SmallerArena(gym.Wrapper):
    """A wrapper that restricts the drivable area: drivers must see its bounds."""

    arena_bounds = (-0.5, 0.5, -0.5, 0.5)


def test_public_attributes_are_read_through_wrappers(tmp_path):
    run = record(
        _SmallerArena(TinyRover()), LoopDriver(insets=(0.1,)), tmp_path / "a.run",
        progress=False,
    )  # fmt: skip
    assert run.metadata["arena_bounds"] == [-0.5, 0.5, -0.5, 0.5] and run.metadata["dt"] == 0.1
    assert np.abs(run.positions).max() < 0.5


# ------------------------------------------------------------------------- SIGTERM

_STALLING_RECORDER = """
import sys, time
sys.path.insert(0, sys.argv[1])
from test_runs import TinyRover, _mower
from sfa_gym.recording.recorder import record

env, steps = TinyRover(), []

def stalling_step(action):
    steps.append(action)
    if len(steps) == 13:  # 13 samples are buffered: signal here
        open(sys.argv[3], "w").close()
        while True:
            time.sleep(0.01)
    return TinyRover.step(env, action)

env.step = stalling_step
record(env, _mower(), sys.argv[2], n_steps=40, chunk_size=100, progress=False)
"""


@pytest.mark.skipif(not hasattr(signal, "SIGTERM") or sys.platform == "win32", reason="POSIX")
def test_sigterm_writes_the_buffered_samples_and_the_run_resumes(tmp_path):
    out, marker = tmp_path / "a.run", tmp_path / "stalled"
    tests = str(Path(__file__).resolve().parent)
    child = subprocess.Popen(
        [sys.executable, "-c", _STALLING_RECORDER, tests, str(out), str(marker)],
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        while not marker.exists():
            assert child.poll() is None, child.stderr.read()
            time.sleep(0.01)
        child.send_signal(signal.SIGTERM)
        assert child.wait(timeout=120) == 128 + signal.SIGTERM
    finally:
        child.kill()
        child.stderr.close()
    partial = load_run(out)
    assert len(partial) == 13 and not partial.complete  # nothing was flushed before the signal
    resumed = record(TinyRover(), _mower(), out, n_steps=40, chunk_size=100, progress=False)
    reference = record(TinyRover(), _mower(), tmp_path / "ref.run", n_steps=40, progress=False)
    _assert_same_run(resumed, reference)
