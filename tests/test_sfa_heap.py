"""Freed memory kept on the heap while SFA trains: fewer page faults, the same model."""

from __future__ import annotations

import contextlib
import json
import os
import subprocess
import sys
import warnings

import numpy as np
import pytest

import sfa_gym.sfa.network as network
from eval.synthetic import synthetic_panoramas
from sfa_gym.sfa import HierarchicalSFA, RankDeficiencyWarning, presets
from sfa_gym.sfa._heap import _glibc

glibc_only = pytest.mark.skipif(_glibc() is None, reason="mallopt is glibc's; a no-op elsewhere")


# Measured in a fresh interpreter: the faults depend on the state of the process's heap, and a
# suite that ran before may have left a free 64 MB chunk in glibc's bins (then even a plain
# allocation reuses mapped pages and "outside" is 0).
_MEASURE = """
import json, resource
import numpy as np
from sfa_gym.sfa._heap import kept_heap

def faults(repeats=3):
    # minor page faults of allocating, touching and freeing a 64 MB array `repeats` times
    before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    for _ in range(repeats):
        block = np.ones(64 * 2**20 // 8)
        del block
    return resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before

outside = faults()
with kept_heap(), kept_heap():  # nested, as the engine's scopes may be
    faults(1)  # the first block grows the heap
    inside = faults()
after = faults()
print(json.dumps({"outside": outside, "inside": inside, "after": after}))
"""


@glibc_only
def test_kept_heap_reuses_freed_pages_and_restores_glibc_on_exit():
    env = {k: v for k, v in os.environ.items() if not k.startswith("MALLOC_")}
    run = subprocess.run(
        [sys.executable, "-c", _MEASURE], capture_output=True, text=True, env=env, check=True
    )
    faults = json.loads(run.stdout.strip().splitlines()[-1])
    assert faults["outside"] > 0  # glibc maps a block this large afresh each time
    assert faults["inside"] < faults["outside"] / 4
    assert faults["after"] > faults["inside"]  # back to glibc's behaviour


def _fit(panoramas: np.ndarray) -> HierarchicalSFA:
    model = HierarchicalSFA(presets.tiny(), n_outputs=4, progress=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RankDeficiencyWarning)
        return model.fit_rotations(panoramas, step=4)


def assert_same_layers(one: HierarchicalSFA, other: HierarchicalSFA) -> None:
    """Every fitted array of the two models' layers is the same to the bit."""
    for a, b in zip(one.layer_params_, other.layer_params_, strict=True):
        for part in ("reduce", "expand"):
            x, y = getattr(a, part), getattr(b, part)
            assert (x is None) == (y is None)
            if x is not None:
                np.testing.assert_array_equal(x.weight, y.weight)
                np.testing.assert_array_equal(x.bias, y.bias)
                np.testing.assert_array_equal(x.delta, y.delta)


def test_keeping_the_heap_changes_no_bit_of_the_model(monkeypatch):
    panoramas = synthetic_panoramas(16, 10, 40, seed=5, n_keyframes=5)
    kept = _fit(panoramas)
    monkeypatch.setattr(network, "kept_heap", contextlib.nullcontext)
    plain = _fit(panoramas)
    assert_same_layers(kept, plain)
    np.testing.assert_array_equal(kept.transform(panoramas), plain.transform(panoramas))
