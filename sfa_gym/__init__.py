"""sfa-gym: visual self-localization and navigation with Slow Feature Analysis."""

from __future__ import annotations

__version__ = "0.1.0"

from sfa_gym.registration import register_envs  # noqa: E402

register_envs()
