"""The ``sfa-gym`` command line, generated from the settings dataclasses with tyro.

- ``sfa-gym record``: drive the rover along a scripted trajectory and record the run
  (:class:`~sfa_gym.cli.record.Record`).
- ``sfa-gym localize``: the paper's simulator experiment, the grid protocol
  (:class:`~sfa_gym.cli.localize.Localize`).
- ``sfa-gym localize-run``: the paper's outdoor protocol on driven runs
  (:class:`~sfa_gym.cli.localize.LocalizeRun`).
- ``sfa-gym localize-outdoor``: the paper's outdoor experiment in the outdoor world, with its
  appearance tracks (:class:`~sfa_gym.cli.localize.LocalizeOutdoor`).
- ``sfa-gym navigate``: image-goal navigation with the slow-feature-gradient controller
  (:class:`~sfa_gym.cli.navigate.Navigate`).
- ``sfa-gym leaderboard run|table``: score methods on the versioned tracks, build the table
  (:class:`~sfa_gym.cli.leaderboard.Leaderboard`).
- ``sfa-gym agent train|eval|play``: a navigation agent trained with PPO, scored, and recorded
  as a GIF or MP4 (:class:`~sfa_gym.cli.agent.Agent`).
- ``sfa-gym export-minari RUN DATASET_ID``: a recorded run as a Minari dataset
  (:class:`~sfa_gym.cli.export.ExportMinari`).
- ``sfa-gym docs-tables [--check]``: the tables of README.md and docs/ from the committed result
  files (:class:`~sfa_gym.cli.docs.DocsTables`).

Each option is a field of a settings dataclass and its help text is the field's docstring;
values are checked by the dataclass's ``validate()``, before anything is written. A bad value
ends the command with a one-line ``error: ...`` on stderr and exit status 2.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from typing import Annotated

import tyro

from sfa_gym.cli.agent import Agent
from sfa_gym.cli.docs import DocsTables
from sfa_gym.cli.export import ExportMinari
from sfa_gym.cli.leaderboard import Leaderboard
from sfa_gym.cli.localize import Localize, LocalizeOutdoor, LocalizeRun
from sfa_gym.cli.navigate import Navigate
from sfa_gym.cli.record import Record
from sfa_gym.plugins import PluginError

__all__ = ["Command", "main"]

Command = (
    Annotated[Record, tyro.conf.subcommand("record")]
    | Annotated[Localize, tyro.conf.subcommand("localize")]
    | Annotated[LocalizeRun, tyro.conf.subcommand("localize-run")]
    | Annotated[LocalizeOutdoor, tyro.conf.subcommand("localize-outdoor")]
    | Annotated[Navigate, tyro.conf.subcommand("navigate")]
    | Annotated[Leaderboard, tyro.conf.subcommand("leaderboard")]
    | Annotated[Agent, tyro.conf.subcommand("agent")]
    | Annotated[ExportMinari, tyro.conf.subcommand("export-minari")]
    | Annotated[DocsTables, tyro.conf.subcommand("docs-tables")]
)
"""The subcommands, one settings dataclass each."""

DESCRIPTION = (
    "Visual self-localization and navigation with Slow Feature Analysis: record runs of the "
    "rover, run the paper's localization protocols and the navigation protocol, train and watch "
    "navigation agents, export runs as Minari datasets."
)


def parse(
    argv: Sequence[str] | None = None,
) -> (
    Record
    | Localize
    | LocalizeRun
    | LocalizeOutdoor
    | Navigate
    | Leaderboard
    | Agent
    | ExportMinari
    | DocsTables
):
    """The command and its settings from ``argv`` (default: ``sys.argv[1:]``); ``--help`` and
    unparsable options exit as argparse does."""
    return tyro.cli(
        Command,  # type: ignore[arg-type]
        args=None if argv is None else list(argv),
        prog="sfa-gym",
        description=DESCRIPTION,
        config=(tyro.conf.OmitSubcommandPrefixes, tyro.conf.FlagCreatePairsOff),
    )


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``sfa-gym`` with ``argv``; returns the exit status (2 for a bad value)."""
    command = parse(argv)
    try:
        return command.run()
    except (ValueError, OSError, PluginError, ImportError) as error:
        print(f"error: {error}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
