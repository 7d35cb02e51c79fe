"""``python -m sfa_gym.cli``: the ``sfa-gym`` command."""

from __future__ import annotations

import sys

from sfa_gym.cli.main import main

sys.exit(main())
