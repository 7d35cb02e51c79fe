"""Feature methods learned by gradient descent from the time order of the training views: the
rotation-invariant network and the training loop that ``baselines/deep_sfa.py`` (the slowness
objective through differentiable whitening) and ``baselines/contrastive.py`` (temporal InfoNCE)
share; each of those files adds only its objective and how its outputs become features.

**Rotation.** The network is invariant to a circular shift of the panorama's columns (a simulated
rotation) by construction, not by averaging: its convolutions are circular along the width with
stride 1 there (a shift of the input shifts every feature map by the same columns), and the maps
are pooled over the width by the magnitudes of their lowest ``n_frequencies`` discrete Fourier
coefficients (a shift changes only the phases). A full-width view of any rotation therefore has
the panorama's own features, up to float32 rounding (~1e-6 relative), so the methods declare
``rotation_invariant``: the protocols fit them on the panoramas themselves and transform each
panorama once. Averaging over rotated copies instead would cost ``W / step`` (70 at 40 x 350)
times as much in training and in every transform; a simulated rotation used as augmentation
would teach approximately what the architecture holds exactly. Unlike column statistics, the
|DFT| pooling keeps how the scene is arranged around the rover (the relative azimuths of its
parts), not only what is in it.

**Pairs.** Training uses pairs of consecutive rows of the same sequence (``sequence_ids``): the
training run's neighbours in time; rows of different sequences are never paired. A fixed number
of ``steps`` (each a batch of ``batch_size`` random pairs), not epochs, bounds the training time
whatever the run's length (624 panoramas on the simulator grid, 5900 outdoor frames).

**Determinism.** With the same ``seed`` and ``n_threads`` the features are the same to the bit:
training runs inside :func:`seeded_torch` (a forked random state seeded with ``seed``,
deterministic algorithms, a fixed thread count), which leaves the caller's torch settings as they
were. torch on the CPU only; it is the optional dependency ``sfa-gym[deep]``.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.exceptions import NotFittedError
from tqdm.auto import tqdm

from sfa_gym._checks import check_int, check_positive, check_positive_int
from sfa_gym.capabilities import Capabilities
from sfa_gym.plugins import check_views, iter_chunks

try:
    import torch
    from torch import nn
except ImportError as error:  # pragma: no cover - the deep extra is not installed
    raise ImportError(
        "the deep feature methods (deep_sfa, contrastive) need torch: pip install 'sfa-gym[deep]'"
    ) from error

__all__ = ["CircularEncoder", "NetworkArgs", "TemporalNetworkMethod", "seeded_torch", "torch"]

VIEWS_PER_PASS = 256
"""Views encoded at once outside training (bounds the memory of the feature maps)."""


@dataclass(frozen=True)
class NetworkArgs:
    """The network and its training, shared by the deep feature methods; every value is checked
    when the arguments are made (before anything is rendered)."""

    output_dim: int = 8
    """number of features (as many as SFA's outputs by default)"""
    steps: int = 400
    """gradient steps (0: the untrained network, a reference for what training adds)"""
    batch_size: int = 64
    """pairs of neighbours in time per step (twice as many views)"""
    learning_rate: float = 1e-3
    """Adam's step size"""
    rows: int = 20
    """the views are averaged down to about this many rows (by a whole factor, height // rows,
    at least 1) before the convolutions: 40 -> 20 on the simulator's panoramas, 60 -> 20 on the
    outdoor ones; never the width, whose every column rotation invariance needs"""
    channels: tuple[int, ...] = (16, 32, 32)
    """output channels of the convolutions (3 x 3, each halving the height, circular along the
    width)"""
    n_frequencies: int = 4
    """lowest Fourier coefficients along the width whose magnitudes pool each feature map (1:
    the mean over the width only)"""
    hidden: int = 64
    """units of the hidden layer between the pooled maps and the outputs"""
    seed: int = 0
    """seed of the initial weights and of the batches"""
    n_threads: int = 2
    """torch threads (the same seed gives the same features only with the same count)"""
    regressor: str = "linear"
    """regression these features are paired with (sfa_gym.localization.regression name)"""
    progress: bool = True
    """a progress bar of the training steps (on a terminal only)"""

    def __post_init__(self) -> None:
        for name in (
            "output_dim",
            "batch_size",
            "rows",
            "n_frequencies",
            "hidden",
            "n_threads",
        ):
            check_positive_int(name, getattr(self, name))
        if check_int("steps", self.steps) < 0:
            raise ValueError(f"steps must be an int >= 0, got {self.steps!r}")
        check_int("seed", self.seed)
        check_positive("learning_rate", self.learning_rate)
        if not isinstance(self.channels, tuple | list) or not self.channels:
            raise ValueError(f"channels must be a non-empty tuple of ints, got {self.channels!r}")
        for channel in self.channels:
            check_positive_int("each of channels", channel)
        if not isinstance(self.regressor, str):
            raise ValueError(f"regressor must be a regression's name, got {self.regressor!r}")
        if not isinstance(self.progress, bool):
            raise ValueError(f"progress must be a bool, got {self.progress!r}")


@contextmanager
def seeded_torch(seed: int, n_threads: int) -> Iterator[None]:
    """torch seeded with ``seed``, deterministic algorithms and ``n_threads`` threads inside; the
    caller's random state, determinism flag and thread count restored after."""
    threads = torch.get_num_threads()
    deterministic = torch.are_deterministic_algorithms_enabled()
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(seed)
        torch.set_num_threads(n_threads)
        torch.use_deterministic_algorithms(True)
        try:
            yield
        finally:
            torch.set_num_threads(threads)
            torch.use_deterministic_algorithms(deterministic)


class CircularEncoder(nn.Module):
    """``(B, H, W, 3)`` uint8 views -> ``(B, output_dim)`` float32, invariant to a circular shift
    of the columns (see the module docstring).

    Args:
        height, width: the views' size.
        rows, channels, n_frequencies, hidden, output_dim: see :class:`NetworkArgs`.
    """

    def __init__(
        self,
        height: int,
        width: int,
        rows: int,
        channels: tuple[int, ...],
        n_frequencies: int,
        hidden: int,
        output_dim: int,
    ) -> None:
        super().__init__()
        if n_frequencies > width // 2 + 1:
            raise ValueError(
                f"n_frequencies must be at most {width // 2 + 1} (W // 2 + 1 for views "
                f"{width} columns wide), got {n_frequencies}"
            )
        sizes = (3, *channels)
        # zeros pad the height; forward pads the width circularly
        self.convolutions = nn.ModuleList(
            nn.Conv2d(c_in, c_out, kernel_size=3, stride=(2, 1), padding=(1, 0))
            for c_in, c_out in zip(sizes[:-1], sizes[1:], strict=True)
        )
        self.row_pool = max(1, height // rows)
        rows = height // self.row_pool
        for _ in channels:
            rows = (rows - 1) // 2 + 1  # kernel 3, padding 1, stride 2
        self.n_frequencies = n_frequencies
        self.head = nn.Sequential(
            nn.Linear(channels[-1] * rows * n_frequencies, hidden),
            nn.ReLU(),
            nn.Linear(hidden, output_dim),
        )

    def forward(self, views: torch.Tensor) -> torch.Tensor:
        x = views.permute(0, 3, 1, 2).float().contiguous() / 255.0 - 0.5  # (B, 3, H, W)
        x = nn.functional.avg_pool2d(x, (self.row_pool, 1))
        for convolution in self.convolutions:
            x = torch.relu(convolution(nn.functional.pad(x, (1, 1, 0, 0), mode="circular")))
        spectrum = torch.fft.rfft(x, dim=3)[..., : self.n_frequencies] / x.shape[3]
        # |c| with a floor inside the root: the gradient of |c| is undefined at c = 0
        magnitude = torch.sqrt(spectrum.real**2 + spectrum.imag**2 + 1e-12)
        return self.head(magnitude.flatten(1))


def neighbour_pairs(n: int, sequence_ids: Any) -> NDArray[np.intp]:
    """Rows ``i`` whose successor ``i + 1`` belongs to the same sequence: ``(P,)``."""
    if sequence_ids is None:
        return np.arange(n - 1, dtype=np.intp)
    ids = np.asarray(sequence_ids)
    if ids.shape != (n,):
        raise ValueError(
            f"sequence_ids must have shape ({n},) (one label per view), got {ids.shape}"
        )
    return np.flatnonzero(ids[1:] == ids[:-1]).astype(np.intp)


class TemporalNetworkMethod(TransformerMixin, BaseEstimator):
    """A :class:`CircularEncoder` trained on pairs of neighbours in time, as a feature method
    (the plug-in contract of :mod:`sfa_gym.plugins`); the parameters are the fields of
    :class:`NetworkArgs`, checked in ``fit``.

    A subclass gives ``name``, :meth:`objective` (the loss of a batch of pairs) and
    :meth:`fit_readout` / :meth:`readout` (how the network's outputs become features).

    Attributes (after ``fit``):
        encoder_: the trained :class:`CircularEncoder`.
        loss_curve_: ``(steps,)`` float64, the loss of each step.
        input_shape_: ``(H, W, 3)``.
    """

    name = "temporal_network"

    def __init__(
        self,
        output_dim: int = NetworkArgs.output_dim,
        steps: int = NetworkArgs.steps,
        batch_size: int = NetworkArgs.batch_size,
        learning_rate: float = NetworkArgs.learning_rate,
        rows: int = NetworkArgs.rows,
        channels: tuple[int, ...] = NetworkArgs.channels,
        n_frequencies: int = NetworkArgs.n_frequencies,
        hidden: int = NetworkArgs.hidden,
        seed: int = NetworkArgs.seed,
        n_threads: int = NetworkArgs.n_threads,
        regressor: str = NetworkArgs.regressor,
        progress: bool = NetworkArgs.progress,
    ) -> None:
        self.output_dim = output_dim
        self.steps = steps
        self.batch_size = batch_size
        self.learning_rate = learning_rate
        self.rows = rows
        self.channels = channels
        self.n_frequencies = n_frequencies
        self.hidden = hidden
        self.seed = seed
        self.n_threads = n_threads
        self.regressor = regressor
        self.progress = progress

    @property
    def capabilities(self) -> Capabilities:
        return Capabilities(
            rotation_invariant=True, regressor=self.regressor, extra_regressors=("map",)
        )

    # -- what a subclass gives -------------------------------------------------------------
    def objective(self, before: torch.Tensor, after: torch.Tensor) -> torch.Tensor:
        """The loss of a batch: outputs ``(B, output_dim)`` at times ``t`` and ``t + 1``."""
        raise NotImplementedError

    def fit_readout(self, outputs: NDArray[np.float64], sequence_ids: Any) -> None:
        """Fit the map from the network's outputs of the training views ``(N, output_dim)`` (in
        time order) to features."""
        raise NotImplementedError

    def readout(self, outputs: NDArray[np.float64]) -> NDArray[np.float64]:
        """Features ``(N, k)`` of the network's outputs ``(N, output_dim)``."""
        raise NotImplementedError

    # -- the estimator ---------------------------------------------------------------------
    def fit(
        self, views: NDArray[np.uint8], sequence_ids: NDArray[np.integer] | None = None
    ) -> TemporalNetworkMethod:
        """Train on ``views (N, H, W, 3)`` uint8 in time order (``sequence_ids (N,)``: separate
        sequences, never paired across)."""
        settings = NetworkArgs(**self.get_params())  # checks every parameter
        views = check_views(views, min_views=2)
        pairs = neighbour_pairs(len(views), sequence_ids)
        per_step = min(settings.batch_size, len(pairs))
        # a step's 2 * per_step views must span the outputs (whitening) and hold a negative
        needed = max(2, settings.output_dim // 2 + 1)
        if per_step < needed:
            raise ValueError(
                f"{self.name} needs at least {needed} pairs of neighbours in time per step "
                f"(2 and more than output_dim / 2); {len(views)} views give {len(pairs)} pairs "
                f"and batch_size is {settings.batch_size}"
            )
        _, height, width, _ = views.shape
        with seeded_torch(settings.seed, settings.n_threads):
            encoder = CircularEncoder(
                height,
                width,
                settings.rows,
                tuple(settings.channels),
                settings.n_frequencies,
                settings.hidden,
                settings.output_dim,
            )
            self.loss_curve_ = self._train(encoder, views, pairs, settings)
            self.encoder_ = encoder.eval()
            outputs = self._encode(views)
        self.fit_readout(outputs, sequence_ids)
        self.input_shape_ = tuple(views.shape[1:])
        return self

    def _train(
        self,
        encoder: CircularEncoder,
        views: NDArray[np.uint8],
        pairs: NDArray[np.intp],
        settings: NetworkArgs,
    ) -> NDArray[np.float64]:
        optimizer = torch.optim.Adam(encoder.parameters(), lr=settings.learning_rate)
        per_step = min(settings.batch_size, len(pairs))
        losses = np.empty(settings.steps)
        order = torch.empty(0, dtype=torch.long)
        bar = tqdm(
            range(settings.steps),
            desc=self.name,
            disable=True if not settings.progress else None,  # None: on a terminal only
        )
        for step in bar:
            if len(order) < per_step:  # a fresh pass over the pairs in a random order
                order = torch.randperm(len(pairs))
            batch, order = pairs[order[:per_step].numpy()], order[per_step:]
            both = torch.from_numpy(np.concatenate([views[batch], views[batch + 1]]))
            outputs = encoder(both)
            loss = self.objective(outputs[:per_step], outputs[per_step:])
            optimizer.zero_grad()
            loss.backward()
            optimizer.step()
            losses[step] = loss.item()
            if not math.isfinite(losses[step]):
                raise FloatingPointError(
                    f"{self.name}: the loss became {losses[step]} at step {step}; lower "
                    f"learning_rate (now {settings.learning_rate})"
                )
        return losses

    def _encode(self, views: NDArray[np.uint8]) -> NDArray[np.float64]:
        out = np.empty((len(views), self.output_dim))
        with torch.inference_mode():
            for part in iter_chunks(len(views), VIEWS_PER_PASS):
                out[part] = self.encoder_(torch.from_numpy(np.ascontiguousarray(views[part])))
        return out

    def network_outputs(self, views: NDArray[np.uint8]) -> NDArray[np.float64]:
        """The trained network's outputs ``(N, output_dim)`` float64, before the readout."""
        if not hasattr(self, "encoder_"):
            raise NotFittedError(f"{self.name} is not fitted yet; call fit(views) first")
        views = check_views(views)
        if tuple(views.shape[1:]) != self.input_shape_:
            raise ValueError(
                f"{self.name} was fitted on views of shape {self.input_shape_}, "
                f"got {tuple(views.shape[1:])}"
            )
        with seeded_torch(self.seed, self.n_threads):
            return self._encode(views)

    def transform(self, views: NDArray[np.uint8]) -> NDArray[np.float64]:
        """``(N, H, W, 3)`` uint8 (the fitted shape) -> ``(N, k)`` float64 features."""
        return self.readout(self.network_outputs(views))
