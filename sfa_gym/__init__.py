"""sfa-gym: visual self-localization and navigation with Slow Feature Analysis."""

from __future__ import annotations

__version__ = "0.1.0"
