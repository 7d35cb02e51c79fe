"""A recorded run exported as a Minari dataset and read back through Minari's own API."""

from __future__ import annotations

import json
import shutil
import sys

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("h5py", reason="the Minari export needs the minari extra (h5py)")
minari = pytest.importorskip("minari", reason="the Minari export needs the minari extra")

from sfa_gym.cli import main  # noqa: E402
from sfa_gym.export import MINARI_EXTRA, export_minari  # noqa: E402
from sfa_gym.recording.drivers import GridPositions, LawnMowerDriver  # noqa: E402
from sfa_gym.recording.recorder import record  # noqa: E402
from sfa_gym.recording.runfile import load_run  # noqa: E402
from sfa_gym.sim.camera import PanoramaSpec  # noqa: E402

ENV_ID = "sfa_gym/OmniRover-v0"
TINY = {"panorama": PanoramaSpec(height=8, width=24)}


def _record(path, driver, **kwargs):
    import sfa_gym  # noqa: F401  (registers the envs)

    kwargs.setdefault("chunk_size", 3)
    return record(ENV_ID, driver, path, env_kwargs=TINY, progress=False, **kwargs)


def _with_header(run, copy, **changes):
    """A copy of the run whose header has these keys changed."""
    shutil.copytree(run, copy)
    header = json.loads((copy / "run.json").read_text())
    (copy / "run.json").write_text(json.dumps({**header, **changes}))
    return copy


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """A 7-sample trajectory run in blocks of 3, a 4-pose pose-list run, and the trajectory
    again in blocks of one sample (8x24 panoramas)."""
    root = tmp_path_factory.mktemp("runs")
    mower = LawnMowerDriver(spacing=1.0, pattern="rows")
    trajectory = _record(root / "mower.run", mower, n_steps=7)
    poses = _record(root / "grid.run", GridPositions(n=2, seed=0))
    mower = LawnMowerDriver(spacing=1.0, pattern="rows")
    ones = _record(root / "ones.run", mower, n_steps=7, chunk_size=1)
    return trajectory.path, poses.path, ones.path


@pytest.fixture(autouse=True)
def datasets(tmp_path, monkeypatch):
    """Minari's local dataset folder, private to each test."""
    folder = tmp_path / "minari"
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(folder))
    return folder


@pytest.mark.parametrize(("which", "block_size"), [(0, 2), (0, 3), (0, 256), (2, 256)])
def test_the_episode_read_back_is_the_run(runs, which, block_size):
    path = runs[which]
    run = load_run(path)
    if which == 2:  # recorded one sample at a time: the same run
        np.testing.assert_array_equal(run.panoramas, load_run(runs[0]).panoramas)
    export_minari(path, "sfa-gym/mower-v0", block_size=block_size)

    dataset = minari.load_dataset("sfa-gym/mower-v0")
    assert dataset.total_episodes == 1 and dataset.total_steps == 6
    (episode,) = list(dataset.iterate_episodes())
    np.testing.assert_array_equal(episode.observations, np.asarray(run.panoramas))
    assert episode.observations.dtype == np.uint8 and len(episode) == 6
    # step i is the command that led from panorama i to panorama i + 1
    np.testing.assert_array_equal(episode.actions, run.actions[1:])
    assert np.abs(episode.actions[:, 0]).max() > 0.1  # the rover was driven
    for i, key in enumerate(("x", "y", "yaw")):
        np.testing.assert_array_equal(episode.infos[key], run.poses[:, i])
    np.testing.assert_array_equal(episode.infos["t"], run.time)
    np.testing.assert_array_equal(episode.rewards, np.zeros(6))
    # the recording stopped at the requested length: a truncation, not a terminal state
    assert run.metadata["end_reason"] == "n_steps"
    assert list(episode.truncations) == [False] * 5 + [True]
    assert not episode.terminations.any()

    assert dataset.observation_space == gym.spaces.Box(0, 255, (8, 24, 3), np.uint8)
    np.testing.assert_array_equal(dataset.action_space.high, np.float32([0.4, 1.0]))  # the env's
    assert dataset.env_spec.id == ENV_ID
    assert dataset.env_spec.kwargs["panorama"]["width"] == 24
    metadata = dataset.storage.metadata
    assert metadata["sfa_gym_run"]["driver"]["type"] == "LawnMowerDriver"
    assert metadata["algorithm_name"] == "sfa-gym LawnMowerDriver"
    assert path.name in metadata["description"]


def test_an_episode_the_env_ended_is_terminated(runs, tmp_path):
    copy = _with_header(runs[0], tmp_path / "ended.run", end_reason="terminated")
    episode = export_minari(copy, "ended-v0")[0]
    assert list(episode.terminations) == [False] * 5 + [True]
    assert not episode.truncations.any()


def test_a_pose_list_run_is_refused(runs, datasets):
    with pytest.raises(ValueError, match=r"pose-list run \(kind 'poses'\).*not a trajectory"):
        export_minari(runs[1], "grid-v0")
    assert not (datasets / "grid-v0").exists()


@pytest.mark.parametrize("dataset_id", ["mower", "sfa-gym/mower", "../mower-v0", "a b-v0", 3])
def test_a_bad_dataset_id_names_the_rule(runs, dataset_id):
    with pytest.raises(ValueError, match=r"\(namespace/\)name-v<version>"):
        export_minari(runs[0], dataset_id)


def test_an_existing_dataset_is_kept_unless_overwritten(runs):
    export_minari(runs[0], "mower-v1", description="first")
    with pytest.raises(ValueError, match=r"'mower-v1' already exists.*overwrite=True"):
        export_minari(runs[0], "mower-v1", description="second")
    assert minari.load_dataset("mower-v1").storage.metadata["description"] == "first"
    export_minari(runs[0], "mower-v1", description="second", overwrite=True)
    dataset = minari.load_dataset("mower-v1")
    assert dataset.storage.metadata["description"] == "second" and dataset.total_steps == 6


def test_an_incomplete_run_is_refused_unless_asked_for(tmp_path):
    def stop(n):
        raise KeyboardInterrupt

    mower = LawnMowerDriver(spacing=1.0, pattern="rows")
    with pytest.raises(KeyboardInterrupt):
        _record(tmp_path / "cut.run", mower, n_steps=9, on_chunk=stop)
    assert len(load_run(tmp_path / "cut.run")) == 3
    with pytest.raises(ValueError, match=r"incomplete \(3 samples.*--incomplete"):
        export_minari(tmp_path / "cut.run", "cut-v0")
    episode = export_minari(tmp_path / "cut.run", "cut-v0", incomplete=True)[0]
    assert len(episode) == 2 and list(episode.truncations) == [False, True]


def test_a_failure_midway_leaves_no_half_written_dataset(runs, datasets, monkeypatch):
    from sfa_gym.export import minari_dataset

    block = minari_dataset._block

    def failing(run, start, *rest):  # after the first blocks are written
        if start >= 6:
            raise OSError("disk full")
        return block(run, start, *rest)

    monkeypatch.setattr(minari_dataset, "_block", failing)
    with pytest.raises(OSError, match="disk full"):
        export_minari(runs[0], "damaged-v0", block_size=3)
    assert not (datasets / "damaged-v0").exists()


def test_without_minari_the_error_names_the_extra(runs, monkeypatch):
    monkeypatch.setitem(sys.modules, "minari", None)  # `import minari` fails as if absent
    with pytest.raises(ImportError, match=MINARI_EXTRA.replace("[", r"\[").replace("]", r"\]")):
        export_minari(runs[0], "mower-v0")


def test_the_command_line_exports_and_explains_refusals(runs, capsys):
    assert main(["export-minari", str(runs[0]), "sfa-gym/cli-v0"]) == 0
    assert "'sfa-gym/cli-v0': 1 episode, 6 steps" in capsys.readouterr().out
    assert minari.load_dataset("sfa-gym/cli-v0").total_steps == 6

    assert main(["export-minari", str(runs[0]), "sfa-gym/cli-v0"]) == 2
    assert "already exists" in capsys.readouterr().err
    assert main(["export-minari", str(runs[0]), "sfa-gym/cli-v0", "--overwrite"]) == 0
    assert main(["export-minari", str(runs[0]), "cli"]) == 2
    assert "name-v<version>" in capsys.readouterr().err
    assert main(["export-minari", str(runs[1]), "grid-v0"]) == 2
    assert "pose-list run" in capsys.readouterr().err


def test_a_run_of_an_env_unknown_here_gets_an_unbounded_action_space(runs, tmp_path):
    # recorded from an env instance, not a registered id
    copy = _with_header(runs[0], tmp_path / "foreign.run", env_id="SomeoneElsesRover")
    dataset = export_minari(copy, "foreign-v0")
    assert dataset.action_space == gym.spaces.Box(-np.inf, np.inf, (2,), np.float32)
    assert dataset.env_spec is None
    assert dataset.storage.metadata["sfa_gym_run"]["env_id"] == "SomeoneElsesRover"
    np.testing.assert_array_equal(dataset[0].actions, load_run(copy).actions[1:])
