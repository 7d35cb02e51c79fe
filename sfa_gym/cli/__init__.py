"""The ``sfa-gym`` command line."""

from __future__ import annotations

from sfa_gym.cli.main import main

__all__ = ["main"]
