"""Recorded runs in the formats of other libraries.

- :mod:`~sfa_gym.export.minari_dataset`: a run as a Minari dataset (offline RL and
  representation learning), :func:`export_minari`; needs ``pip install 'sfa-gym[minari]'``.

Kept outside :mod:`sfa_gym.recording`, whose code enters the render cache's key: a change to an
exporter must not invalidate the cached runs.
"""

from __future__ import annotations

from sfa_gym.export.minari_dataset import MINARI_EXTRA, export_minari

__all__ = ["MINARI_EXTRA", "export_minari"]
