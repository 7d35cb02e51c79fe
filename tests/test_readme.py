"""The README's example runs as printed."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

README = Path(__file__).resolve().parents[1] / "README.md"


def test_readme_example_runs_and_gives_slow_features():
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(), flags=re.DOTALL)
    assert len(blocks) == 1, "the README should carry exactly one Python example"
    scope: dict = {}
    exec(compile(blocks[0], str(README), "exec"), scope)
    obs, info = scope["obs"], scope["info"]
    assert obs.shape == (8,) and obs.dtype == np.float32
    assert np.all(np.isfinite(obs))
    assert {"x", "y", "yaw"} <= set(info)
    assert scope["env"].observation_space.contains(obs)
    scope["env"].close()
