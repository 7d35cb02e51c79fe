"""torch after rendering: Mesa's llvmpipe and torch's triton each carry an LLVM; the package
loads triton before its first GL context, so that training after rendering does not crash.

Run in a fresh interpreter: the crash is a SIGSEGV that would take pytest down with it.
"""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
import textwrap

import pytest

pytestmark = pytest.mark.skipif(
    importlib.util.find_spec("stable_baselines3") is None,
    reason="stable-baselines3 is not installed (the test extra installs it)",
)


@pytest.fixture
def run_fresh(tmp_path):
    """Runs ``code`` in a fresh interpreter whose temp folder is the test's own: SB3's default
    logger makes an ``SB3-<time>`` folder there at every ``learn()``."""

    def run(code: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run(
            [sys.executable, "-c", textwrap.dedent(code)],
            capture_output=True,
            text=True,
            timeout=600,
            env={**os.environ, "TMPDIR": str(tmp_path)},
        )

    return run


def test_ppo_trains_after_the_env_has_rendered(run_fresh):
    done = run_fresh(
        """
        import gymnasium as gym
        import sfa_gym
        from sfa_gym.sim.camera import PanoramaSpec
        from stable_baselines3 import PPO

        env = gym.make("sfa_gym/OmniRover-v0", panorama=PanoramaSpec(width=64, height=8))
        env.reset(seed=0)  # the first render loads Mesa's LLVM
        model = PPO("MlpPolicy", env, n_steps=64, batch_size=64, n_epochs=2, seed=0)
        model.learn(total_timesteps=256)  # builds the optimizer: torch imports triton
        print("trained", model.num_timesteps)
        """
    )
    assert done.returncode == 0, f"exit {done.returncode}\n{done.stderr[-2000:]}"
    assert "trained 256" in done.stdout


def test_an_optimizer_after_the_top_down_render(run_fresh):
    done = run_fresh(
        """
        import gymnasium as gym
        import sfa_gym
        import torch

        env = gym.make("sfa_gym/OmniRover-v0", render_mode="rgb_array")
        frame = env.unwrapped.render()  # the top-down renderer makes the first context
        torch.optim.Adam(torch.nn.Linear(2, 2).parameters())
        print("ok", frame.shape)
        """
    )
    assert done.returncode == 0, f"exit {done.returncode}\n{done.stderr[-2000:]}"
    assert "ok (256, 256, 3)" in done.stdout


def test_ppo_trains_on_the_rendered_navigation_env_in_subprocess_workers(run_fresh):
    # two workers render image-goal episodes; the policy sees both panoramas (MultiInputPolicy:
    # a CNN per image); the parent has rendered too, so the workers are spawned
    done = run_fresh(
        """
        import gymnasium as gym
        import sfa_gym
        from sfa_gym.sim.camera import PanoramaSpec
        from stable_baselines3 import PPO
        from stable_baselines3.common.env_util import make_vec_env
        from stable_baselines3.common.vec_env import SubprocVecEnv

        def make():
            return gym.make("sfa_gym/OmniRoverNav-v0", panorama=PanoramaSpec(width=96, height=40),
                            stop_action=False)

        if __name__ == "__main__":
            make().reset(seed=0)  # the parent renders first
            venv = make_vec_env(make, n_envs=2, seed=0, vec_env_cls=SubprocVecEnv,
                                vec_env_kwargs={"start_method": "spawn"})
            model = PPO("MultiInputPolicy", venv, n_steps=64, batch_size=64, n_epochs=1, seed=0)
            model.learn(total_timesteps=256)
            print("trained", model.num_timesteps)
        """
    )
    assert done.returncode == 0, f"exit {done.returncode}\n{done.stderr[-2000:]}"
    assert "trained 256" in done.stdout
