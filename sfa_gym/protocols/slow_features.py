"""Hierarchical SFA as a feature method: the network of :class:`SFASettings`, fitted on every
simulated rotation of a sequence of panoramas, as every protocol and the leaderboard's ``sfa``
plug-in (``baselines/sfa.py``) train it. A method, not feature machinery (:mod:`sfa_gym.features`):
it stays beside the settings it is made from, and out of the envs' start-up (scikit-learn)."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray
from sklearn.base import BaseEstimator, TransformerMixin

from sfa_gym.protocols.settings import SFASettings
from sfa_gym.rotation import Rotation

__all__ = ["SlowFeatureMethod"]


class SlowFeatureMethod(TransformerMixin, BaseEstimator):
    """Hierarchical SFA as a feature method: fitted on all simulated rotations of a sequence of
    panoramas (:meth:`HierarchicalSFA.fit_rotations`), regressed linearly as in the paper.

    Parameters:
        settings: the network.
        rotation: the simulated rotation it is trained on (default: 5 columns, full views).
        progress: progress bars while fitting.

    Attributes (after fitting):
        model_: the fitted :class:`~sfa_gym.sfa.HierarchicalSFA`.
        input_shape_: ``(H, W, 3)`` of the views it transforms.
    """

    name = "hierarchical_sfa"

    def __init__(
        self,
        settings: SFASettings = SFASettings(),  # noqa: B008  (frozen: shared safely)
        rotation: Rotation = Rotation(),  # noqa: B008
        progress: bool = True,
    ) -> None:
        self.settings = settings
        self.rotation = rotation
        self.progress = progress

    def fit_rotations(
        self, panoramas: NDArray[np.uint8], appearances: int = 1
    ) -> SlowFeatureMethod:
        """Fit on ``panoramas (L, H, W, 3)`` in visiting order, with all their rotations (runs of
        ``appearances`` consecutive panoramas: one location, see
        :meth:`HierarchicalSFA.fit_rotations`)."""
        _, h, w, _ = panoramas.shape
        model = self.settings.make_model(h, w, self.progress)
        self.model_ = model.fit_rotations(
            panoramas,
            step=self.rotation.step,
            window=self.rotation.window,
            appearances=appearances,
        )
        self.input_shape_ = self.model_.input_shape_
        return self

    def fit(self, views: NDArray[np.uint8], sequence_ids: Any = None) -> SlowFeatureMethod:
        """Fit on ``views (N, H, W, 3)`` in time order."""
        _, h, w, _ = views.shape
        self.model_ = self.settings.make_model(h, w, self.progress).fit(
            views, sequence_ids=sequence_ids
        )
        self.input_shape_ = self.model_.input_shape_
        return self

    def transform(self, views: NDArray[np.uint8]) -> NDArray[np.float64]:
        """``(N, H, W, 3)`` uint8 -> ``(N, n_outputs)`` slow features."""
        return self.model_.transform(views)

    def transform_rotations(
        self, panoramas: NDArray[np.uint8], step: int, indices: Any = None
    ) -> NDArray[np.float64]:
        """Features of the ``step``-column rotations ``indices`` (all by default) of each
        panorama, ``(L, K', n_outputs)``, computed with the rotation shortcut (the lower layers
        run once per panorama; the rotations asked for are picked from all). ``step`` may differ
        from the training rotation's: a feature field averages over every column (step 1) of a
        network trained with 5-column rotations."""
        return self.model_.transform_rotations(panoramas, step, indices)
