"""Input normalisations: they cancel a change of the light, commute with the simulated rotation,
keep what tells places apart, and refuse bad input."""

from __future__ import annotations

import numpy as np
import pytest

from sfa_gym.localization.appearance import normalise_panoramas


def _scenes(seed: int = 0) -> np.ndarray:
    """Two smooth, coloured 12 x 40 panoramas of different places (values 40..220)."""
    rng = np.random.default_rng(seed)
    base = rng.uniform(40, 220, size=(2, 3, 8, 3))
    # upsample blocks: neighbouring pixels are alike, as in a rendered scene
    return np.kron(base, np.ones((1, 4, 5, 1))).round().astype(np.uint8)


def _dimmed(panoramas: np.ndarray, gain: np.ndarray) -> np.ndarray:
    return np.clip(np.rint(panoramas * gain), 0, 255).astype(np.uint8)


@pytest.mark.parametrize("mode", ["grey_world", "log_gradient"])
def test_a_change_of_the_light_cancels(mode):
    scenes = _scenes()
    warm_and_dim = _dimmed(scenes, np.array([0.7, 0.6, 0.45]))
    plain = normalise_panoramas(scenes, mode).astype(float)
    changed = normalise_panoramas(warm_and_dim, mode).astype(float)
    raw_change = np.abs(scenes.astype(float) - warm_and_dim).mean()
    left = np.abs(plain - changed)
    if mode == "log_gradient":
        # the gain cancels in the gradients; the red/blue chromaticity keeps the colour cast
        left = left[..., :2]
    assert raw_change > 40 and left.mean() < 2.0, (raw_change, left.mean())
    # what tells the two places apart survives
    assert np.abs(plain[0] - plain[1]).mean() > 5 * max(left.mean(), 0.5)


@pytest.mark.parametrize("mode", ["none", "grey_world", "log_gradient"])
def test_normalising_commutes_with_the_rotation(mode):
    scenes = _scenes(1)
    rolled = np.roll(scenes, -7, axis=2)
    np.testing.assert_array_equal(
        normalise_panoramas(rolled, mode), np.roll(normalise_panoramas(scenes, mode), -7, axis=2)
    )


def test_none_is_the_identity_and_chunks_do_not_matter():
    scenes = np.concatenate([_scenes(s) for s in range(3)])
    assert normalise_panoramas(scenes, "none") is scenes
    np.testing.assert_array_equal(
        normalise_panoramas(scenes, "log_gradient", chunk=2),
        normalise_panoramas(scenes, "log_gradient"),
    )


@pytest.mark.parametrize(
    ("panoramas", "mode", "match"),
    [
        (np.zeros((1, 4, 8, 3), np.uint8), "histogram", r"normalisation must be one of"),
        (np.zeros((4, 8, 3), np.uint8), "grey_world", r"\(L, H, W, 3\) uint8, got \(4, 8, 3\)"),
        (np.zeros((1, 4, 8, 3)), "grey_world", "float64"),
    ],
)
def test_bad_input_is_named(panoramas, mode, match):
    with pytest.raises(ValueError, match=match):
        normalise_panoramas(panoramas, mode)
