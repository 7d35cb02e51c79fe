"""Where the environment data (world specs) is found."""

from __future__ import annotations

from pathlib import Path


def envs_dir() -> Path:
    """Directory with the world specs: inside the installed wheel, or ``envs/`` of a checkout."""
    package = Path(__file__).resolve().parents[2]  # .../sfa_gym
    for candidate in (package / "envs_data", package.parent / "envs"):
        if candidate.is_dir():
            return candidate
    raise FileNotFoundError(
        f"sfa_gym's environment data is missing: neither {package / 'envs_data'} nor "
        f"{package.parent / 'envs'} exists; reinstall the package"
    )
