"""The PPO navigation agent (baselines/agents/ppo_nav.py): it trains on a real feature field and
on rendered panoramas, writes its learning curve and checkpoint, resumes, and refuses bad
arguments. Small budgets: these check the machinery, not the agent's skill (the sweep in
studies/ppo_nav_sweep.py measures that)."""

from __future__ import annotations

import dataclasses
import importlib.util
import math
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("stable_baselines3", reason="the test extra installs stable-baselines3")

from sfa_gym.localization.methods import load_method_file  # noqa: E402
from sfa_gym.navigation.field import FeatureField  # noqa: E402
from sfa_gym.sim.env import OmniRoverEnv  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def _agent():
    spec = importlib.util.spec_from_file_location("ppo_nav", ROOT / "baselines/agents/ppo_nav.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def agent():
    return _agent()


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
    method = load_method_file(ROOT / "baselines/band_means.py")().fit(train)
    field = FeatureField.build(env, method, spacing=0.5, progress=False)
    env.close()
    path = tmp_path_factory.mktemp("field") / "field_band_means.npz"
    field.save(path)
    return path


def _small(agent, out: Path, **kwargs):
    settings = dict(
        out=out, total_timesteps=512, n_envs=2, n_steps=64, batch_size=64, n_epochs=2,
        eval_every=256, eval_episodes=2, progress=False,
    )  # fmt: skip
    return agent.Args(**{**settings, **kwargs})


def test_trains_on_a_feature_field_writes_its_curve_and_resumes(agent, field_path, tmp_path):
    from stable_baselines3 import PPO

    args = _small(agent, tmp_path / "run", field=field_path)
    curve = agent.train(args)
    assert [row["steps"] for row in curve] == [0, 256, 512]
    for row in curve:
        assert 0 <= row["success"] <= 1 and 0 <= row["spl"] <= row["success"]
        assert row["final_distance"] >= 0
    assert agent.load_curve(args.out / agent.CURVE) == curve  # floats round-trip exactly
    assert (args.out / "learning_curve.png").stat().st_size > 0
    model = PPO.load(args.out / "model.zip", device="cpu")  # our own file
    assert model.num_timesteps == 512
    k = FeatureField.load(field_path).n_features
    assert model.observation_space.shape == (2 * k + (args.history - 1) * (k + 2),)
    # no temporary files are left behind
    assert sorted(p.name for p in args.out.iterdir()) == sorted(
        [agent.CHECKPOINT, agent.CURVE, "learning_curve.png", "model.zip"]
    )

    # started again with a larger budget, it continues from the checkpoint
    resumed = agent.train(dataclasses.replace(args, total_timesteps=1024))
    assert resumed[:3] == curve
    assert [row["steps"] for row in resumed[3:]] == [768, 1024]
    assert resumed[-1]["seconds"] >= curve[-1]["seconds"]


def test_the_memory_holds_feature_changes_beside_the_moves_in_the_body_frame(agent, field_path):
    field = FeatureField.load(field_path)
    k = field.n_features
    memory = agent.FeatureHistory(field, history=3, stride=1)
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


def test_trains_a_cnn_on_rendered_panoramas(agent, tmp_path):
    args = _small(agent, tmp_path / "pixels", total_timesteps=64, n_envs=1, n_steps=64,
                  eval_every=64, eval_episodes=1)  # fmt: skip
    curve = agent.train(args)
    assert [row["steps"] for row in curve] == [0, 64]
    env = agent.make_env(args)
    obs, _ = env.reset(seed=0)
    assert obs.shape == (40, 350, 6) and obs.dtype == np.uint8
    env.close()


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [({"reward": "dense"}, "reward"), ({"eval_every": 0}, "eval_every"), ({"n_envs": 0}, "n_envs")],
)
def test_bad_arguments_are_refused(agent, tmp_path, kwargs, match):
    with pytest.raises(ValueError, match=match):
        agent.train(_small(agent, tmp_path, **kwargs))


def test_a_file_that_is_not_a_learning_curve_is_refused(agent, tmp_path):
    (tmp_path / agent.CURVE).write_text("a,b\n1,2\n")
    with pytest.raises(ValueError, match="not a learning curve"):
        agent.load_curve(tmp_path / agent.CURVE)


def test_the_oracle_observes_the_goal_in_the_body_frame(agent, field_path, tmp_path):
    env = agent.make_env(_small(agent, tmp_path, field=field_path, oracle=True))
    obs, _ = env.reset(seed=0, options={"start": (0.0, 0.0, math.pi / 2), "goal": (1.0, 0.5, 0)})
    # facing north, the goal 1 m east and 0.5 m north is 0.5 m ahead and 1 m to the right
    np.testing.assert_allclose(obs, [0.5, -1.0, 0.0, 1.0], atol=1e-3)
    env.close()
    with pytest.raises(ValueError, match="oracle needs a field"):
        agent.make_env(_small(agent, tmp_path, oracle=True))


def test_the_goal_estimate_is_the_goals_displacement_where_features_are_linear(agent):
    # features linear in position: the local fit is exact, and its Gauss-Newton step (damped
    # by 10 % of the trace) points at the goal
    mixing = np.array([[1.0, 0.2], [-0.3, 0.8], [0.5, 0.5]])
    xs = ys = np.linspace(-3, 3, 7)
    gx, gy = np.meshgrid(xs, ys)
    values = np.stack([gx, gy], axis=-1) @ mixing.T
    weights = [1.0, 2.0, 0.5]
    field = FeatureField(values, (-3, 3, -3, 3), metadata={"model_info": {"cost_weights": weights}})
    memory = agent.FeatureHistory(field, history=2, stride=1, estimate=True)
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
        agent.FeatureHistory(FeatureField(values, (-3, 3, -3, 3)), 2, 1, estimate=True)


def test_the_range_readings_end_the_observation(agent, field_path, tmp_path):
    env = agent.make_env(_small(agent, tmp_path, field=field_path, ranges=True))
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


def test_anneal_lr_decays_the_learning_rate_over_the_budget(agent, field_path, tmp_path):
    from stable_baselines3 import PPO

    for anneal in (False, True):
        args = _small(agent, tmp_path / str(anneal), field=field_path, anneal_lr=anneal)
        agent.train(args)
        model = PPO.load(args.out / "model.zip", device="cpu")  # our own file
        rate = model.policy.optimizer.param_groups[0]["lr"]
        if anneal:
            # SB3 sets the rate after each rollout: the last one ends the budget
            assert rate == 0.0
            assert model.lr_schedule(0.5) == pytest.approx(args.learning_rate / 2)
        else:
            assert rate == pytest.approx(args.learning_rate)
