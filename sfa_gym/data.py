"""Where the environment data (world specs, MJCF parts) is found."""

from __future__ import annotations

from pathlib import Path


def envs_dir() -> Path:
    """Directory with the world specs: inside the installed wheel, or ``envs/`` of a checkout."""
    here = Path(__file__).resolve().parent
    for candidate in (here / "envs_data", here.parent / "envs"):
        if candidate.is_dir():
            return candidate
    raise FileNotFoundError(
        f"sfa_gym's environment data is missing: neither {here / 'envs_data'} nor "
        f"{here.parent / 'envs'} exists; reinstall the package"
    )
