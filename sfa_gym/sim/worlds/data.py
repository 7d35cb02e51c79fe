"""Where the world specs are found (:func:`sfa_gym.data.data_folder`, kind ``"envs"``)."""

from __future__ import annotations

from pathlib import Path

from sfa_gym.data import data_folder


def envs_dir() -> Path:
    """Directory with the world specs: ``envs/`` of a checkout, or the installed wheel's copy."""
    return data_folder("envs")
