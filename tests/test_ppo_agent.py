"""The navigation agents (sfa_gym.agents, ``sfa-gym agent train|eval|play``): real PPO training
on a real feature field and on rendered panoramas, the learning curve and checkpoints, resuming,
scoring a saved model, recording a rollout, and refusing bad arguments. Small budgets: these
check the machinery, not the agent's skill (eval/studies/ppo_nav_sweep.py measures that)."""

from __future__ import annotations

import dataclasses
import math
import re
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("stable_baselines3", reason="the test extra installs stable-baselines3")

from sfa_gym.agents import AgentEnv, FeatureHistory, make_env  # noqa: E402
from sfa_gym.agents.training import CURVE, Training, latest_checkpoint, load_curve, train  # noqa: E402
from sfa_gym.cli.main import main  # noqa: E402
from sfa_gym.navigation.field import FeatureField  # noqa: E402
from sfa_gym.plugins import load_method_plugin  # noqa: E402
from sfa_gym.sim.env import OmniRoverEnv  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SMALL = Training(total_timesteps=512, n_envs=2, n_steps=64, batch_size=64, n_epochs=2,
                 eval_every=256, eval_episodes=2)  # fmt: skip
SMALL_ARGS = (
    "--total-timesteps 512 --n-envs 2 --n-steps 64 --batch-size 64 --n-epochs 2 --eval-every 256 "
    "--eval-episodes 2 --quiet"
).split()


@pytest.fixture(scope="module")
def field_path(tmp_path_factory) -> Path:
    """Band means of rendered panoramas on a 0.5 m grid of the open arena: a real, coarse field."""
    env = OmniRoverEnv("paper_sim", 0, "paper_sim")
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    xmin, xmax, ymin, ymax = env.arena_bounds
    train = np.stack([
        env.reset(options={"pose": (x, y, 0.0)})[0]
        for x, y in rng.uniform((xmin, ymin), (xmax, ymax), size=(20, 2))
    ])  # fmt: skip
    method = load_method_plugin(ROOT / "baselines/band_means.py")().fit(train)
    field = FeatureField.build(env, method, spacing=0.5, progress=False)
    env.close()
    path = tmp_path_factory.mktemp("field") / "field_band_means.npz"
    field.save(path)
    return path


@pytest.fixture(scope="module")
def run(field_path, tmp_path_factory) -> Path:
    """An agent trained for 512 steps by ``sfa-gym agent train``."""
    out = tmp_path_factory.mktemp("agent") / "run"
    assert main(["agent", "train", "--out", str(out), "--field", str(field_path), *SMALL_ARGS]) == 0
    return out


def test_train_writes_the_curve_checkpoints_and_model_and_resumes(
    run, field_path, tmp_path, capsys, monkeypatch
):
    from stable_baselines3 import PPO

    curve = load_curve(run / CURVE)
    assert [row["steps"] for row in curve] == [256, 512]
    for row in curve:
        assert 0 <= row["success"] <= 1 and 0 <= row["spl"] <= row["success"]
        assert row["final_distance"] >= 0
    assert (run / "learning_curve.png").stat().st_size > 0
    model = PPO.load(run / "model.zip", device="cpu")  # our own file
    assert model.num_timesteps == 512
    k = FeatureField.load(field_path).n_features
    assert model.observation_space.shape == (2 * k + 7 * (k + 2),)
    assert sorted(p.name for p in (run / "checkpoints").iterdir()) == [
        "ppo_256_steps.zip", "ppo_512_steps.zip"
    ]  # fmt: skip
    # no temporary files are left behind
    assert sorted(p.name for p in run.iterdir()) == sorted(
        ["agent.json", "checkpoints", CURVE, "learning_curve.png", "model.zip"]
    )
    # with a constant rate the optimiser keeps it
    assert model.policy.optimizer.param_groups[0]["lr"] == pytest.approx(SMALL.learning_rate)

    # started again with a larger budget, it continues from the newest checkpoint that loads:
    # here the 256-step one, the 512-step one cut short as by a crash while it was written
    resumed_run = tmp_path / "resumed"
    shutil.copytree(run, resumed_run)
    newest = resumed_run / "checkpoints" / "ppo_512_steps.zip"
    newest.write_bytes(newest.read_bytes()[:1000])
    env = AgentEnv(field=field_path)
    system_temp = tmp_path / "tmp"
    system_temp.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(system_temp))
    resumed = train(resumed_run, env, dataclasses.replace(SMALL, total_timesteps=1024), False)
    assert list(system_temp.iterdir()) == []  # nothing left in the system's temporary folder
    assert "skipped checkpoint" in capsys.readouterr().err
    assert resumed[:1] == curve[:1]  # floats round-trip exactly; the 512-step row is redone
    assert [row["steps"] for row in resumed[1:]] == [512, 768, 1024]
    assert resumed[-1]["seconds"] >= curve[0]["seconds"]
    assert latest_checkpoint(resumed_run).name == "ppo_1024_steps.zip"
    assert PPO.load(resumed_run / "model.zip", device="cpu").num_timesteps == 1024

    # the folder's agent was trained on other settings: refused, not mixed
    with pytest.raises(ValueError, match="other env settings"):
        train(resumed_run, dataclasses.replace(env, ranges=True), SMALL, False)


def _printed(text: str, name: str) -> float:
    return float(re.search(rf"{name} (-?[0-9.]+)", text).group(1))


def test_eval_loads_a_checkpoint_and_scores_the_trainings_evaluation_again(run, capsys):
    # the 512-step checkpoint is the policy the 512-step evaluation scored, on the same seeds
    checkpoint = run / "checkpoints" / "ppo_512_steps.zip"
    assert main(["agent", "eval", "--run", str(run), "--model", str(checkpoint),
                 "--episodes", "2", "--quiet"]) == 0  # fmt: skip
    printed = capsys.readouterr().out
    row = load_curve(run / CURVE)[-1]
    assert "2 episodes (seeds 10000-10001)" in printed
    assert _printed(printed, "success") == pytest.approx(row["success"], abs=0.005)
    assert _printed(printed, "final distance") == pytest.approx(row["final_distance"], abs=0.005)
    assert _printed(printed, "return") == pytest.approx(row["return"], abs=0.005)


def test_play_records_a_gif_of_the_top_down_view_beside_the_panorama(run, tmp_path, capsys):
    import imageio.v2 as imageio

    out = tmp_path / "rollout.gif"
    assert main(["agent", "play", "--run", str(run), "--out", str(out), "--max-steps", "4",
                 "--render-size", "64", "--quiet"]) == 0  # fmt: skip
    assert "5 frames" in capsys.readouterr().out
    frames = imageio.mimread(out)
    # the first frame and one a step; a 40 x 350 panorama beside the 64 x 64 top-down view
    assert len(frames) == 5
    assert {f.shape[:2] for f in frames} == {(64, 64 + 350)}
    # the panorama is rendered, not black: a feature agent's env renders none itself
    assert frames[0][20, 64:].std() > 0
    from PIL import Image

    with Image.open(out) as gif:  # the env's 10 steps a second
        assert gif.info["duration"] == 100


def test_play_records_an_mp4_when_imageio_ffmpeg_is_there(run, tmp_path):
    pytest.importorskip("imageio_ffmpeg")
    import imageio.v3 as imageio

    from sfa_gym.agents.rollout import record_rollout

    out = tmp_path / "rollout.mp4"
    done = record_rollout(run, out, max_steps=3, render_size=64, progress=False)
    assert done.frames == 4 and done.steps == 3
    assert imageio.imread(out).shape == (4, 64, 64 + 350, 3)


@pytest.mark.parametrize(
    ("argv", "match"),
    [
        (["train", "--out", "{tmp}/x", "--reward", "dense"], "reward must be one of"),
        (["train", "--out", "{tmp}/x", "--n-envs", "0"], "n_envs must be a positive int, got 0"),
        (["train", "--out", "{tmp}/x", "--eval-every", "0"], "eval_every"),
        (["train", "--out", "{tmp}/x", "--field", "{tmp}/none.npz"], "is not a file"),
        (["train", "--out", "{tmp}/x", "--oracle"], "oracle needs a field"),
        (["train", "--out", "{tmp}/x", "--env-id", "sfa_gym/OmniRover-v0"], "env_id must be one"),
        (["eval", "--run", "{tmp}"], "agent.json does not exist"),
        (["eval", "--run", "{run}", "--episodes", "0"], "episodes must be a positive int, got 0"),
        (["eval", "--run", "{run}", "--model", "{tmp}/none.zip"], "is not a file"),
        (["play", "--run", "{run}", "--out", "{tmp}/x.avi"], r"out must end in one of"),
        (["play", "--run", "{run}", "--out", "{tmp}/x.gif", "--max-steps", "0"], "max_steps"),
    ],
)
def test_bad_arguments_get_a_clear_error(run, tmp_path, capsys, argv, match):
    argv = [a.format(tmp=tmp_path, run=run) for a in argv]
    assert main(["agent", *argv, "--quiet"]) == 2
    assert re.search(match, capsys.readouterr().err)
    assert not (tmp_path / "x").exists()  # refused before anything is written


def test_a_file_that_is_not_a_learning_curve_is_refused(tmp_path):
    (tmp_path / CURVE).write_text("a,b\n1,2\n")
    with pytest.raises(ValueError, match="not a learning curve"):
        load_curve(tmp_path / CURVE)


def test_the_memory_holds_feature_changes_beside_the_moves_in_the_body_frame(field_path):
    field = FeatureField.load(field_path)
    k = field.n_features
    memory = FeatureHistory(field, history=3, stride=1)
    values = field.values.reshape(-1, k)
    now = np.stack([memory({"features": v, "goal_features": v}, {"odometry": np.zeros(3)}, True)
                    for v in values])[:, k : 2 * k]  # fmt: skip
    np.testing.assert_allclose(now.mean(axis=0), 0, atol=1e-5)  # standardised over the field
    np.testing.assert_allclose(now.std(axis=0), 1, atol=1e-4)

    # drive east 1 m, then turn to face north: that move went to the rover's right
    f = [memory.standardise(v) for v in values[:4]]
    goal = values[3]
    memory({"features": values[0], "goal_features": goal}, {"odometry": np.zeros(3)}, True)
    memory({"features": values[1], "goal_features": goal}, {"odometry": [1.0, 0, 0]}, False)
    out = memory(
        {"features": values[2], "goal_features": goal}, {"odometry": [1.0, 0, np.pi / 2]}, False
    )
    assert out.shape == memory.space.shape == (2 * k + 2 * (k + 2),)
    np.testing.assert_allclose(out[:k], f[3] - f[2], rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(out[k : 2 * k], f[2], rtol=1e-5, atol=1e-6)
    blocks = out[2 * k :].reshape(2, k + 2)  # the latest move first
    np.testing.assert_allclose(blocks[0, :k], f[2] - f[1], rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(blocks[1, :k], f[2] - f[0], rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(blocks[:, k:], [[0, 0], [0, -1]], atol=1e-6)


def test_trains_a_cnn_on_rendered_panoramas(tmp_path):
    settings = dataclasses.replace(SMALL, total_timesteps=64, n_envs=1, n_steps=64,
                                   eval_every=64, eval_episodes=1)  # fmt: skip
    curve = train(tmp_path / "pixels", AgentEnv(), settings, progress=False)
    assert [row["steps"] for row in curve] == [64]
    env = make_env(AgentEnv())
    obs, _ = env.reset(seed=0)
    assert obs.shape == (40, 350, 6) and obs.dtype == np.uint8
    env.close()


def test_the_oracle_observes_the_goal_in_the_body_frame(field_path):
    env = make_env(AgentEnv(field=field_path, oracle=True))
    obs, _ = env.reset(seed=0, options={"start": (0.0, 0.0, math.pi / 2), "goal": (1.0, 0.5, 0)})
    # facing north, the goal 1 m east and 0.5 m north is 0.5 m ahead and 1 m to the right
    np.testing.assert_allclose(obs, [0.5, -1.0, 0.0, 1.0], atol=1e-3)
    env.close()
    with pytest.raises(ValueError, match="oracle needs a field"):
        make_env(AgentEnv(oracle=True))


def test_the_goal_estimate_is_the_goals_displacement_where_features_are_linear():
    # features linear in position: the local fit is exact, and its Gauss-Newton step (damped
    # by 10 % of the trace) points at the goal
    mixing = np.array([[1.0, 0.2], [-0.3, 0.8], [0.5, 0.5]])
    xs = ys = np.linspace(-3, 3, 7)
    gx, gy = np.meshgrid(xs, ys)
    values = np.stack([gx, gy], axis=-1) @ mixing.T
    weights = [1.0, 2.0, 0.5]
    field = FeatureField(values, (-3, 3, -3, 3), metadata={"model_info": {"cost_weights": weights}})
    memory = FeatureHistory(field, history=2, stride=1, estimate=True)
    goal = mixing @ [1.0, 2.0]
    out = None
    for i, (x, y) in enumerate([(0, 0), (0.1, 0), (0.1, 0.1), (0.0, 0.15), (0.05, 0.05)]):
        features = mixing @ [x, y]
        out = memory({"features": features, "goal_features": goal},
                     {"odometry": [x, y, math.pi / 2]}, i == 0)  # fmt: skip
        if i < 2:  # two positions do not span the plane yet
            np.testing.assert_array_equal(out[-3:], 0)
    metric = mixing.T @ (np.array(weights)[:, None] * mixing)
    step = np.linalg.solve(metric + 0.1 * np.trace(metric) * np.eye(2), metric @ [0.95, 1.95])
    # facing north: east is to the right (-y in the body frame), north is ahead (+x)
    np.testing.assert_allclose(out[-3:], [step[1], -step[0], 1.0], atol=1e-6)
    assert out.shape == memory.space.shape

    with pytest.raises(ValueError, match="cost_weights"):
        FeatureHistory(FeatureField(values, (-3, 3, -3, 3)), 2, 1, estimate=True)


def test_the_range_readings_end_the_observation(field_path):
    env = make_env(AgentEnv(field=field_path, ranges=True))
    obs, info = env.reset(seed=3)
    k = FeatureField.load(field_path).n_features
    rays = env.unwrapped.range_rays
    assert rays > 0 and obs.shape == env.observation_space.shape
    assert obs.shape == (2 * k + 7 * (k + 2) + rays,)
    for _ in range(5):
        obs, *_, info = env.step(np.array([1.0, 0.3], dtype=np.float32))
    np.testing.assert_allclose(obs[-rays:], info["range"], rtol=1e-6)
    # the rays see something: the arena's walls are within the sensor's range somewhere
    assert np.all(obs[-rays:] > 0) and np.all(obs[-rays:] <= env.unwrapped.range_max)
    env.close()


def test_anneal_lr_decays_the_learning_rate_over_the_budget(field_path, tmp_path):
    from stable_baselines3 import PPO

    settings = dataclasses.replace(SMALL, anneal_lr=True)
    train(tmp_path / "anneal", AgentEnv(field=field_path), settings, progress=False)
    model = PPO.load(tmp_path / "anneal" / "model.zip", device="cpu")  # our own file
    # SB3 sets the rate after each rollout: the last one ends the budget
    assert model.policy.optimizer.param_groups[0]["lr"] == 0.0
    assert model.lr_schedule(0.5) == pytest.approx(settings.learning_rate / 2)


def test_a_missing_package_names_the_extra_to_install():
    from sfa_gym.cli.agent import _require

    _require("stable_baselines3")  # installed: nothing to say
    with pytest.raises(ImportError, match=r"no_such_package_here: pip install 'sfa-gym\[sb3\]'"):
        _require("stable_baselines3", "no_such_package_here")


@pytest.mark.parametrize(
    ("command", "classes"),
    [("train", (AgentEnv, Training)), ("eval", ()), ("play", ())],
)
def test_help_lists_every_setting(command, classes, capsys, monkeypatch):
    monkeypatch.setenv("COLUMNS", "200")  # one option per line, however long
    with pytest.raises(SystemExit) as exit_:
        main(["agent", command, "--help"])
    assert exit_.value.code == 0
    printed = capsys.readouterr().out
    for cls in classes:
        for field in dataclasses.fields(cls):
            assert "--" + field.name.replace("_", "-") in printed
    assert "--quiet" in printed and ("--run" in printed) == (command != "train")
