"""The leaderboard: track files refused with clear errors, plug-ins loaded by path alone, the
shared render cache (one render for concurrent workers, damaged entries re-rendered), the same
scores from the local and the Ray backend, and the command line end to end."""

from __future__ import annotations

import copy
import dataclasses
import json
import multiprocessing
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from sfa_gym.capabilities import Capabilities
from sfa_gym.leaderboard.results import SCHEMA_VERSION
from sfa_gym.leaderboard.tracks import TrackError, list_tracks, load_track, track_from_dict
from sfa_gym.navigation.controllers import GradientSettings
from sfa_gym.plugins import PluginError, file_sha256, load_method
from sfa_gym.recording.cache import RunCache, RunRequest
from sfa_gym.recording.drivers import GridPositions
from sfa_gym.sim.env import OmniRoverEnv

ROOT = Path(__file__).resolve().parents[1]
BAND_MEANS = ROOT / "baselines" / "band_means.py"

# a track small enough for tests: 6 x 6 grid, 10 x 40 panoramas
TINY = {
    "schema_version": 1,
    "name": "tiny",
    "track_version": 1,
    "kind": "localization",
    "evaluation": "train_test",
    "description": "test track",
    "world": "paper_sim",
    "world_seeds": [100, 101],
    "seed": 7001,
    "params": {
        "panorama": [10, 40],
        "grid": 6,
        "n_train": 20,
        "n_test": 12,
        "order": "hilbert",
        "step": 5,
    },
    "quick": {"world_seeds": 1},
}


def _write_track(folder: Path, data: dict) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{data['name']}.json"
    path.write_text(json.dumps(data))
    return path


def band_means_fitting(path: Path, body: str) -> Path:
    """Write band_means at ``path`` with the statements ``body`` run first in its ``fit``."""
    statements = textwrap.indent(textwrap.dedent(body).strip(), " " * 8)
    path.write_text(
        BAND_MEANS.read_text()
        + f"""

class Variant(BandMeans):
    def fit(self, views, sequence_ids=None):
{statements}
        return super().fit(views, sequence_ids)


def make_method(**args):
    return Variant(**args)
"""
    )
    return path


# ----------------------------------------------------------------------------- tracks


def test_shipped_tracks_load_and_stay_clear_of_development_seeds():
    tracks = {t.name: t for t in list_tracks(ROOT / "tracks")}
    assert {"paper_sim_parity", "train_test", "few_labels", "unvisited_region"} <= set(tracks)
    assert {"unseen_worlds", "nav_open", "nav_obstacles", "nav_maze"} <= set(tracks)
    assert tracks["few_labels"].params["labels"] == [12, 25, 50]
    unseen = tracks["unseen_worlds"]
    assert not set(unseen.fit_world_seeds) & set(unseen.world_seeds)


def test_a_tracks_params_are_its_protocols_config():
    from sfa_gym.protocols import grid, trajectory

    tracks = {t.name: t for t in list_tracks(ROOT / "tracks")}
    full = tracks["few_labels"].config(quick=False)
    assert full == grid.Config(
        world="paper_sim",
        panorama=(40, 350),
        grid=30,
        n_train=624,
        n_test=196,
        evaluations=("few_labels",),
        labels=(12, 25, 50),
        seed=7001,
    )
    # the quick size is the full one on fewer world seeds: at smaller grids the learning
    # methods' features are rank deficient and the board ranked methods otherwise
    assert tracks["few_labels"].config(quick=True) == full
    assert tracks["few_labels"].sized(True)[0] == tracks["few_labels"].world_seeds[:2]
    assert tracks["unseen_worlds"].config(quick=False).evaluations == ("train_test",)
    region = tracks["unvisited_region"].config(quick=True)
    assert isinstance(region, trajectory.Config)
    assert (region.spacing, region.exclude, region.eval_rotations) == (
        0.5,
        (-3, -1.5, -3, -1.5),
        14,
    )
    maze = tracks["nav_maze"]
    assert maze.config(quick=True) == dataclasses.replace(maze.config(quick=False), episodes=40)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda d: d.update(schema_version=2), "unknown schema_version 2"),
        (lambda d: d.pop("world_seeds"), "missing field 'world_seeds'"),
        (lambda d: d["params"].update(n_tset=64), "unknown field 'params.n_tset' for train_test"),
        (lambda d: d["params"].update(grid=0), "tiny.json: params: grid must be a positive int"),
        (
            lambda d: d["quick"].update(params={"n_test": 40}),
            r"tiny.json: quick.params: n_train \+ n_test = 60 positions do not fit on a 6 x 6",
        ),
        (lambda d: d["params"].update(seed=3), "'params.seed' is set by the track"),
        (lambda d: d["params"].update(evaluations=["paper_splits"]), "'params.evaluations' is set"),
        (lambda d: d.update(world_seeds=[100, 3]), "world_seeds 3 is a development seed"),
        (lambda d: d.update(seed=0), "seed 0 is a development seed"),
        (lambda d: d.update(colour="red"), "unknown field 'colour'"),
        (lambda d: d.update(kind="navigation"), "does not match evaluation"),
    ],
)
def test_bad_track_is_refused_naming_the_value(change, message):
    data = copy.deepcopy(TINY)
    change(data)
    with pytest.raises(TrackError, match=message):
        track_from_dict(data, "tiny.json")


def test_navigation_episode_seeds_must_avoid_the_readme_episodes():
    data = json.loads((ROOT / "tracks" / "nav_open.json").read_text())
    data["params"]["episode_seed"] = 950  # episodes 950..1049 reach the README's 1000-1099
    with pytest.raises(TrackError, match="params.episode_seed 1000 is a development seed"):
        track_from_dict(data, "nav_open.json")


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda c: c.pop("memory"), "missing field 'params.gradient.memory'"),
        (lambda c: c.update(speed_limit=1.0), "unknown setting 'gradient.speed_limit'"),
        (lambda c: c.update(memory=-1.0), "memory must be a positive number, got -1.0"),
    ],
)
def test_navigation_tracks_fix_every_controller_setting(change, message):
    data = json.loads((ROOT / "tracks" / "nav_open.json").read_text())
    track = track_from_dict(copy.deepcopy(data), "nav_open.json")
    # track version 3 keeps the controller settings version 2 was scored with (version 3
    # changed only the controller's arithmetic to the portable one): the library's defaults since
    # then search out of stalls (searches, search_after, search_found, give_up)
    scored_with = dataclasses.replace(
        GradientSettings(), searches=0, search_after=4.0, search_found=0.5, give_up=6.0
    )
    assert track.track_version == 3
    assert GradientSettings(**track.params["gradient"]) == scored_with
    change(data["params"]["gradient"])
    with pytest.raises(TrackError, match=message):
        track_from_dict(data, "nav_open.json")


def test_every_world_of_the_shipped_tracks_builds():
    # e.g. paper_sim_obstacles finds no room for its six obstacles with world seed 100
    from sfa_gym.sim.worlds import build_world, load_world_spec

    for track in list_tracks(ROOT / "tracks"):
        spec = load_world_spec(track.world)
        for seed in track.world_seeds + track.fit_world_seeds:
            build_world(spec, seed)


def test_navigation_tracks_drive_the_env_of_their_world():
    import gymnasium as gym

    for track in list_tracks(ROOT / "tracks"):
        if track.kind == "navigation":
            kwargs = gym.spec(track.params["env_id"]).kwargs
            assert kwargs["world"] == track.world, track.name


def test_track_name_must_match_its_file(tmp_path):
    path = tmp_path / "other.json"
    path.write_text(json.dumps(TINY))
    with pytest.raises(TrackError, match="differs from the file name 'other'"):
        load_track(path)


# ---------------------------------------------------------------------------- plug-ins

SPY = "from pathlib import Path\nPath(__file__).with_name('{name}.imported').write_text('x')\n"


def test_plugin_without_protocol_names_what_is_missing(tmp_path):
    no_factory = tmp_path / "no_factory.py"
    no_factory.write_text(
        "from dataclasses import dataclass\n@dataclass\nclass Args:\n  a: int = 1\n"
    )
    with pytest.raises(PluginError, match="neither make_method"):
        load_method(no_factory)
    no_args = tmp_path / "no_args.py"
    no_args.write_text("def make_method(**kw):\n    return None\n")
    with pytest.raises(PluginError, match="no Args dataclass"):
        load_method(no_args)
    not_a_method = tmp_path / "not_a_method.py"
    not_a_method.write_text(
        "from dataclasses import dataclass\n@dataclass\nclass Args:\n  a: int = 1\n"
        "class M:\n  name = 'm'\n  def fit(self, v): return self\n"
        "def make_method(**kw):\n  return M()\n"
    )
    with pytest.raises(PluginError, match=r"missing or wrong: \['transform'\]"):
        load_method(not_a_method)
    with pytest.raises(ValueError, match="unknown argument 'n_band'"):
        load_method(BAND_MEANS, {"n_band": 3})


def test_loading_a_plugin_imports_nothing_else_from_its_folder(tmp_path):
    folder = tmp_path / "pkg"
    folder.mkdir()
    (folder / "__init__.py").write_text(SPY.format(name="init"))
    (folder / "helpers.py").write_text(SPY.format(name="helpers"))
    (folder / "method.py").write_text(BAND_MEANS.read_text())
    path_before, modules_before = list(sys.path), set(sys.modules)
    method = load_method(folder / "method.py", {"n_bands": 2})
    assert method.name == "band_means" and method.get_params()["n_bands"] == 2
    assert not list(folder.glob("*.imported"))
    assert sys.path == path_before
    new = set(sys.modules) - modules_before
    assert all(name.startswith("sfa_gym_plugin_method_") for name in new), new


# ------------------------------------------------------------------------------- cache


def _request(seed: int = 7001) -> RunRequest:
    return RunRequest(
        world="paper_sim",
        world_seed=100,
        panorama=(8, 24),
        driver=GridPositions(n=2, seed=seed, order="raster"),
        seed=seed,
    )


def _ask(root: str) -> list:
    run = RunCache(root).get(_request())
    return np.asarray(run.panoramas).tolist()


def test_a_run_folder_keeps_its_runs_by_name_and_reuses_them(tmp_path):
    from sfa_gym.recording.cache import RunFolder

    folder = RunFolder(tmp_path, {"grid": _request()})
    first = folder.get(_request())
    assert first.path == tmp_path / "grid.run" and first.complete
    stamp = (tmp_path / "grid.run" / "run.json").stat().st_mtime_ns
    again = folder.get(_request())
    assert (tmp_path / "grid.run" / "run.json").stat().st_mtime_ns == stamp
    np.testing.assert_array_equal(again.panoramas, first.panoramas)
    # the same pixels as the shared cache renders for the same request
    np.testing.assert_array_equal(
        RunCache(tmp_path / "cache").get(_request()).panoramas, first.panoramas
    )
    with pytest.raises(KeyError, match=r"keeps the runs \['grid'\]"):
        folder.get(_request(seed=7002))


def test_a_request_may_leave_world_and_camera_to_the_env():
    own = dataclasses.replace(_request(), world=None, panorama=None)
    content = own.key_content()
    assert content["world"] == "paper_sim" and content["panorama"] is None
    assert content["world_spec_sha256"] == _request().key_content()["world_spec_sha256"]
    assert own.record_kwargs() == {"world_seed": 100}
    assert set(_request().record_kwargs()) == {"world", "world_seed", "panorama"}


def test_two_processes_asking_for_the_same_run_render_it_once(tmp_path):
    context = multiprocessing.get_context("spawn")
    with context.Pool(2) as pool:
        first, second = pool.map(_ask, [str(tmp_path)] * 2)
    cache = RunCache(tmp_path)
    assert len(cache.renders()) == 1
    assert first == second
    assert len(list(tmp_path.glob("*.run"))) == 1
    assert not list(tmp_path.glob(".*tmp*"))


@pytest.mark.skipif(sys.platform != "linux", reason="the Linux folders")
def test_the_default_cache_folder_is_the_users_cache_unless_sfa_gym_cache_says(
    tmp_path, monkeypatch
):
    from sfa_gym.recording.cache import default_cache_dir

    monkeypatch.delenv("SFA_GYM_CACHE", raising=False)
    monkeypatch.delenv("XDG_CACHE_HOME", raising=False)
    monkeypatch.setenv("HOME", str(tmp_path))
    assert default_cache_dir() == tmp_path / ".cache" / "sfa-gym" / "runs"
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "scratch"))
    assert default_cache_dir() == tmp_path / "scratch" / "sfa-gym" / "runs"
    monkeypatch.setenv("SFA_GYM_CACHE", str(tmp_path / "shared"))
    assert default_cache_dir() == tmp_path / "shared"
    assert RunCache().root == tmp_path / "shared"


def test_a_killed_render_resumes_and_a_truncated_entry_is_rendered_again(tmp_path):
    cache = RunCache(tmp_path)
    before = np.asarray(cache.get(_request()).panoramas)
    entry = cache.path(_request())
    header = json.loads((entry / "run.json").read_text())
    (entry / "run.json").write_text(json.dumps({**header, "complete": False, "n": 2}))
    np.testing.assert_array_equal(cache.get(_request()).panoramas, before)
    file = entry / "panoramas.npy"
    data = file.read_bytes()
    file.write_bytes(data[: len(data) // 2])
    after = np.asarray(cache.get(_request()).panoramas)
    assert len(cache.renders()) == 3
    np.testing.assert_array_equal(before, after)
    assert file.read_bytes() == data
    # what determines the pixels is in the key: another heading seed is another entry
    assert cache.path(_request(seed=7002)) != cache.path(_request())


def test_a_fresh_process_whose_first_step_is_the_cache_renders_headless(tmp_path):
    # the key hashes the MuJoCo version: reading it must not import mujoco before the GL
    # backend is chosen, or MuJoCo stays on GLFW and a headless render fails
    code = (
        "import sys\n"
        "from sfa_gym.recording.cache import RunCache, RunRequest\n"
        "from sfa_gym.recording.drivers import GridPositions\n"
        "request = RunRequest(world='paper_sim', world_seed=100, panorama=(8, 24),\n"
        "    driver=GridPositions(n=2, seed=7001, order='raster'), seed=7001)\n"
        f"cache = RunCache({str(tmp_path)!r})\n"
        "cache.path(request)\n"
        "assert 'mujoco' not in sys.modules, 'the cache key imported mujoco'\n"
        "print(cache.get(request).panoramas.shape)\n"
    )
    env = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "PYOPENGL_PLATFORM")}
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, check=False
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip().endswith("(4, 8, 24, 3)")


# the SHA-256 of the pixels of _request() (a 4-pose grid, 8 x 24 panoramas) and the
# RENDERING_VERSION it was rendered at
FIXED_SCENE = {
    "rendering_version": 3,
    "pixels_sha256": "d2d9f60b2ea026204503cd45f12fc06f398fc83d9c85f662e4b48a39e1c6fea9",
}


def test_pixels_change_only_with_the_rendering_version(tmp_path):
    import hashlib

    from sfa_gym.recording.cache import RENDERING_VERSION

    run = RunCache(tmp_path).get(_request())
    found = {
        "rendering_version": RENDERING_VERSION,
        "pixels_sha256": hashlib.sha256(np.asarray(run.panoramas).tobytes()).hexdigest(),
    }
    assert found == FIXED_SCENE, (
        f"the fixed scene renders {found}, not {FIXED_SCENE}: when pixels change, bump "
        "RENDERING_VERSION in sfa_gym/recording/cache.py and update FIXED_SCENE here"
    )
    assert "mujoco" in _request().key_content()


# ---------------------------------------------------------------------- backends, CLI


def test_local_and_ray_backends_give_the_same_scores(tmp_path):
    pytest.importorskip("ray", reason="ray is not installed (pip install 'sfa-gym[ray]')")
    import ray

    from sfa_gym.leaderboard.backends import run_tasks
    from sfa_gym.leaderboard.evaluate import Task

    track = _write_track(tmp_path / "tracks", TINY)
    tasks = [
        Task(str(track), str(BAND_MEANS), {}, seed, False, str(tmp_path / "cache"))
        for seed in (100, 101)
    ]
    local = run_tasks(tasks, "local")
    try:
        remote = run_tasks(tasks, "ray", num_cpus=2)
    finally:
        ray.shutdown()
    assert [o["scores"] for o in local] == [o["scores"] for o in remote]
    assert local[0]["scores"]["score"] != local[1]["scores"]["score"]  # two different worlds
    assert len(RunCache(tmp_path / "cache").renders()) == 2  # Ray reused the local renders


def test_ray_backend_without_ray_names_the_extra(monkeypatch):
    from sfa_gym.leaderboard import backends

    monkeypatch.setitem(sys.modules, "ray", None)
    with pytest.raises(ImportError, match=r"pip install 'sfa-gym\[ray\]'"):
        backends.run_tasks([], "ray")


def test_cli_run_and_table_write_results_with_provenance(tmp_path, capsys):
    from sfa_gym.cli.main import main

    tracks = tmp_path / "tracks"
    _write_track(tracks, TINY)
    results = tmp_path / "results"
    common = ["--tracks", str(tracks), "--results", str(results), "--cache", str(tmp_path / "c")]
    status = main(
        ["leaderboard", "run", "--method", str(BAND_MEANS), "--track", "tiny", "--quick", *common]
    )
    assert status == 0
    stored = json.loads((results / "tiny" / "band_means.quick.json").read_text())
    assert stored["schema_version"] == SCHEMA_VERSION
    (result,) = stored["results"]
    assert result["track_version"] == 1 and result["backend"] == "local"
    assert list(result["per_world_seed"]) == ["100"]  # quick: the first world seed
    assert result["score"]["n"] == 1 and result["score"]["ci95"] is None
    assert 0 < result["score"]["mean"] < 50  # MAE in % of the range: far better than chance
    (task,) = [json.loads(p.read_text()) for p in (results / "tasks").rglob("*.json")]
    assert task["identity"]["method"]["args"]["n_bands"] == 8  # all of them, defaults too
    assert task["provenance"]["sfa_gym_version"] and result["versions"]

    status = main(
        [
            "leaderboard",
            "run",
            "--method",
            "band_means",  # the built-in, by name
            "--track",
            "tiny",
            "--method-args",
            "n_bands=2",
            *common,
        ]
    )
    assert status == 0
    (full,) = json.loads((results / "tiny" / "band_means[n_bands=2].json").read_text())["results"]
    assert full["method_sha256"] == file_sha256(BAND_MEANS)
    # two seeds: too few for an interval (sfa_gym.intervals.MIN_SEEDS)
    assert full["score"]["n"] == 2 and full["score"]["interval"] == "t-clipped"
    assert full["score"]["ci95"] is None and full["score"]["std"] is not None

    assert main(["leaderboard", "table", "--results", str(results)]) == 0
    table = (results / "LEADERBOARD.md").read_text()
    assert "| band_means[n_bands=2] |" in table and "tiny (quick)" in table
    assert (results / "leaderboard.png").stat().st_size > 1000

    assert main(["leaderboard", "run", "--method", str(BAND_MEANS), "--track", "nope", *common])
    assert "'nope' is not a track" in capsys.readouterr().err
    # a value of the wrong type is refused before any task, naming the field
    wrong = ["leaderboard", "run", "--method", "band_means", "--method-args", "n_bands=two"]
    assert main([*wrong, "--track", "tiny", *common]) == 2
    assert "argument n_bands must be int, got 'two'" in capsys.readouterr().err


# -------------------------------------------------------------------------- navigation

NAV_TINY = {
    "schema_version": 1,
    "name": "nav_tiny",
    "track_version": 1,
    "kind": "navigation",
    "evaluation": "navigation",
    "description": "test track",
    "world": "paper_sim_obstacles",
    "world_seeds": [101],
    "seed": 7001,
    "params": {
        "env_id": "sfa_gym/OmniRoverNavObstacles-v0",
        "train_grid": 5,
        "train_headings": "random",
        "hilbert_axes": "yx",
        "field_spacing": 1.5,
        "episodes": 2,
        "episode_seed": 50000,
        "weight_power": 2.0,
        "gradient": dataclasses.asdict(GradientSettings()),
    },
    "quick": {"world_seeds": 1},
}


class _MeanColour:
    """A cheap fitted feature model: the mean colour of a panorama, the same for every
    rotation (``rotation_invariant``: no rotated views are built)."""

    capabilities = Capabilities(rotation_invariant=True)

    def transform(self, panoramas):
        return np.asarray(panoramas, dtype=np.float64).mean(axis=(1, 2))


class _TopRowColour(_MeanColour):
    """Another cheap model: the mean colour of the top row."""

    def transform(self, panoramas):
        return super().transform(np.asarray(panoramas)[:, :1])


@pytest.fixture(scope="module")
def obstacles_nav():
    import gymnasium as gym

    env = gym.make("sfa_gym/OmniRoverNavObstacles-v0", world_seed=101).unwrapped
    yield env
    env.close()


@pytest.fixture(scope="module")
def obstacles_camera():
    """The exploration env of the same world (its reset places the rover at a pose)."""
    env = OmniRoverEnv("paper_sim_obstacles", world_seed=101)
    yield env
    env.close()


def test_free_grid_positions_skip_exactly_the_cells_reset_refuses(obstacles_camera):
    from sfa_gym.recording.poses import FreeGridPositions

    every = GridPositions(n=12, seed=7001, order="hilbert").poses(obstacles_camera)
    free = FreeGridPositions(n=12, seed=7001, order="hilbert").poses(obstacles_camera)
    kept = [any(np.array_equal(p, q) for q in free) for p in every]
    assert 0 < len(free) < len(every)  # the obstacles take some cells, not all
    np.testing.assert_array_equal(every[kept], free)  # same poses, same yaws, same order
    for pose in every[~np.array(kept)][:3]:
        with pytest.raises(ValueError, match="from an obstacle"):
            obstacles_camera.reset(options={"pose": tuple(pose)})
    # in the open arena the rover fits everywhere: the whole grid, as GridPositions
    open_arena = OmniRoverEnv()
    try:
        np.testing.assert_array_equal(
            FreeGridPositions(n=6, seed=3).poses(open_arena),
            GridPositions(n=6, seed=3).poses(open_arena),
        )
    finally:
        open_arena.close()


def test_cached_field_is_the_built_field_and_its_panoramas_serve_every_method(
    obstacles_nav, obstacles_camera, tmp_path
):
    from sfa_gym.navigation.field import FeatureField
    from sfa_gym.protocols.navigation import feature_field

    cache = RunCache(tmp_path)
    built = FeatureField.build(
        obstacles_camera,
        _MeanColour(),
        spacing=1.5,
        free=obstacles_nav.occupancy.is_free,
        progress=False,
    )
    field = feature_field(obstacles_nav, _MeanColour(), 1.5, cache, seed=7001)
    np.testing.assert_array_equal(field.free, built.free)
    assert not field.free.all()  # nodes inside obstacles, filled from their neighbours
    np.testing.assert_allclose(field.values, built.values, rtol=0, atol=1e-9)
    field.check_env(obstacles_nav)  # the metadata names this world and camera
    other = feature_field(obstacles_nav, _TopRowColour(), 1.5, cache, seed=7001)
    assert len(cache.renders()) == 1  # the second method's field reused the panoramas
    assert not np.allclose(other.values, field.values)  # its own features


# a cheap plug-in: the mean colour of the top ``rows`` rows, the same for every rotation
MEAN_COLOUR_PLUGIN = """
from dataclasses import dataclass
import numpy as np
from sfa_gym.capabilities import Capabilities

@dataclass(frozen=True)
class Args:
    rows: int = 40

class MeanColour:
    name = "mean_colour"
    capabilities = Capabilities(rotation_invariant=True)
    def __init__(self, rows):
        self.rows = rows
    def fit(self, views):
        return self
    def transform(self, views):
        return np.asarray(views[:, : self.rows], dtype=np.float64).mean(axis=(1, 2))

def make_method(rows=40):
    return MeanColour(rows)
"""


def test_navigation_task_in_the_obstacle_world_reuses_the_renders(tmp_path):
    from sfa_gym.files import strict_json
    from sfa_gym.leaderboard.evaluate import Task, run_task

    track = _write_track(tmp_path / "tracks", NAV_TINY)
    plugin = tmp_path / "mean_colour.py"
    plugin.write_text(MEAN_COLOUR_PLUGIN)
    cache = tmp_path / "cache"
    first = run_task(Task(str(track), str(plugin), {}, 101, False, str(cache)))
    scores = first["scores"]
    assert 0.0 <= scores["score"] <= 1.0 and scores["episodes"] == 2
    assert 0 < scores["training_positions"] < 25  # the grid minus the cells in obstacles
    assert scores["field_nodes"]["free"] < scores["field_nodes"]["nodes"] == 25
    assert len(RunCache(cache).renders()) == 2  # training grid and field nodes
    strict_json(first)  # a result file can hold it (no NaN, e.g. without interior episodes)
    if scores["interior"]["episodes"] == 0:
        assert scores["interior"]["success"] is None
    # where the time went: every phase of a navigation task, adding up to the task's seconds
    assert set(first["phases"]) == {"render", "fit", "features", "episodes", "other"}
    assert sum(first["phases"].values()) == pytest.approx(first["seconds"], abs=0.1)
    second = run_task(Task(str(track), str(plugin), {"rows": 2}, 101, False, str(cache)))
    assert len(RunCache(cache).renders()) == 2  # another method: no new render
    # read from the cache, not rendered: a small part of the first task's render phase
    assert second["phases"]["render"] < first["phases"]["render"] / 4
    assert second["phases"]["episodes"] > 0
    assert second["scores"]["training_positions"] == scores["training_positions"]


def test_an_empty_track_folder_is_refused(tmp_path, capsys):
    from sfa_gym.cli.main import main

    (tmp_path / "tracks").mkdir()
    args = ["leaderboard", "run", "--method", "band_means", "--tracks", str(tmp_path / "tracks")]
    assert main([*args, "--results", str(tmp_path / "results")]) == 2
    assert "no track file in" in capsys.readouterr().err
    assert not (tmp_path / "results").exists()
