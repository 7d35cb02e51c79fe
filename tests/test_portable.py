"""The navigation step's portable arithmetic: it agrees with numpy's, and gives the same bits
under another CPU's kernels (numpy's AVX-512 targets off, OpenBLAS's Nehalem kernels)."""

from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from sfa_gym.navigation import portable

ROOT = Path(__file__).resolve().parents[1]


def test_exp_is_within_two_ulp_of_the_exact_value():
    x = np.random.default_rng(0).uniform(-40.0, 40.0, 20_000)
    exact = np.array([math.exp(v) for v in x])  # glibc: correctly rounded in practice
    ulps = np.abs(portable.exp(x) - exact) / np.spacing(exact)
    assert ulps.max() <= 2.0
    assert portable.exp(0.0) == 1.0
    assert portable.exp(-800.0) == 0.0
    assert portable.exp(1.0).shape == ()


def test_small_linear_algebra_matches_numpy():
    rng = np.random.default_rng(1)
    for _ in range(50):
        a, f, w = rng.normal(size=(30, 3)), rng.normal(size=(30, 5)), rng.uniform(size=30)
        np.testing.assert_allclose(portable.gram(a, f, w), a.T @ (w[:, None] * f), rtol=1e-12)
        np.testing.assert_allclose(portable.gram(a, f), a.T @ f, rtol=1e-12, atol=1e-12)
        m = portable.gram(a, a, w) + np.eye(3)
        np.testing.assert_allclose(portable.solve(m, f[:3]), np.linalg.solve(m, f[:3]), rtol=1e-9)
        np.testing.assert_allclose(
            portable.solve(m[:2, :2], f[0, :2]), np.linalg.solve(m[:2, :2], f[0, :2]), rtol=1e-9
        )
        assert portable.smallest_eigenvalue(m[:2, :2]) == pytest.approx(
            np.linalg.eigvalsh(m[:2, :2])[0], rel=1e-9, abs=1e-12
        )
        assert portable.norm2(f[0, :2]) == pytest.approx(np.linalg.norm(f[0, :2]), rel=1e-15)


def test_solve_refuses_singular_and_other_shapes():
    with pytest.raises(np.linalg.LinAlgError, match="singular"):
        portable.solve(np.ones((2, 2)), np.ones(2))
    with pytest.raises(ValueError, match=r"2 x 2 or 3 x 3, got shape \(4, 4\)"):
        portable.solve(np.eye(4), np.ones(4))


SCRIPT = """
import hashlib, numpy as np
from sfa_gym.navigation import portable
from sfa_gym.navigation.feature_gradient import LocalLinearFit, gauss_newton_step
from sfa_gym.navigation.field import FeatureField
rng = np.random.default_rng(2)
digest = hashlib.sha256()
weights = rng.uniform(0.5, 2.0, 8)
fit = LocalLinearFit(weights, memory=0.3, window=1.0, prior=0.02)
for t in range(300):
    position = np.array([np.cos(t / 20), np.sin(t / 31)]) * t / 100
    fit.remember(position, rng.normal(size=8))
    found = fit.fit()
    if found is not None:
        a, jacobian, noise = found
        step = gauss_newton_step(a, jacobian, rng.normal(size=8), weights, 0.1)
        digest.update(np.concatenate([a, jacobian.ravel(), [noise, fit.spread], step]).tobytes())
field = FeatureField(rng.normal(size=(9, 11, 8)), (0.0, 2.0, 0.0, 1.6))
for p in rng.uniform(0.0, 1.6, (200, 2)):
    digest.update(field.at(float(p[0]), float(p[1])).tobytes())
digest.update(field(rng.uniform(0.0, 1.6, (50, 2))).tobytes())
print(digest.hexdigest())
"""


def _digest(**env: str) -> str:
    out = subprocess.run(
        [sys.executable, "-c", SCRIPT],
        cwd=ROOT,
        env={**os.environ, **env},
        capture_output=True,
        text=True,
        check=True,
    )
    return out.stdout.strip()


def test_the_step_gives_the_same_bits_under_another_cpus_kernels():
    # the fit, the Gauss-Newton step, the field's table and both of its look-ups
    other_cpu = {
        "NPY_DISABLE_CPU_FEATURES": "X86_V4 AVX512_ICL AVX512_SPR",
        "OPENBLAS_CORETYPE": "Nehalem",
    }
    assert _digest() == _digest(**other_cpu)
