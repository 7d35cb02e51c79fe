"""Navigation agents trained with stable-baselines3: the env factory and observation wrappers
(:mod:`sfa_gym.agents.env`, :mod:`sfa_gym.agents.observations`), training
(:mod:`sfa_gym.agents.training`), scoring (:mod:`sfa_gym.agents.evaluation`) and recording a
rollout (:mod:`sfa_gym.agents.rollout`); on the command line ``sfa-gym agent train|eval|play``.

Training, scoring and loading need the ``sb3`` extra (stable-baselines3); recording needs
imageio. The model files are SB3's zip, which SB3's loader partly unpickles: load only model
files you made yourself.
"""

from sfa_gym.agents.env import AgentEnv, make_env
from sfa_gym.agents.observations import FeatureHistory, GoalVector, StackedPanoramas, WithHistory

__all__ = [
    "AgentEnv",
    "FeatureHistory",
    "GoalVector",
    "StackedPanoramas",
    "WithHistory",
    "make_env",
]
