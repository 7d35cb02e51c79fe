"""Navigation in slow-feature space: goal tasks, odometry, occupancy and geodesic distance,
feature fields, controllers and metrics.

The env is :class:`sfa_gym.navigation.env.OmniRoverNavEnv` (ids ``sfa_gym/OmniRoverNav-v0``
and variants); import it from its module (it loads MuJoCo).
"""

from sfa_gym.navigation.metrics import soft_spl, spl, summarize_episodes
from sfa_gym.navigation.occupancy import GeodesicField, OccupancyGrid
from sfa_gym.navigation.odometry import WheelOdometry

__all__ = [
    "GeodesicField",
    "OccupancyGrid",
    "WheelOdometry",
    "soft_spl",
    "spl",
    "summarize_episodes",
]
