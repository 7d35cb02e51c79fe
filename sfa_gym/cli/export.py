"""``sfa-gym export-minari RUN DATASET_ID``: a recorded run as a local Minari dataset
(:mod:`sfa_gym.export.minari_dataset`)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Annotated

import tyro

__all__ = ["ExportMinari"]


@dataclass(frozen=True)
class ExportMinari:
    """Write a recorded run (panoramas, actions, poses) as a Minari dataset of one episode, into
    $MINARI_DATASETS_PATH (default ~/.minari/datasets); load it with
    minari.load_dataset(DATASET_ID). Needs pip install 'sfa-gym[minari]'."""

    run_path: Annotated[Path, tyro.conf.Positional, tyro.conf.arg(metavar="RUN")]
    """the run directory (<name>.run) written by sfa-gym record"""
    dataset_id: Annotated[str, tyro.conf.Positional, tyro.conf.arg(metavar="DATASET_ID")]
    """the dataset's id, (namespace/)name-v<version>, e.g. sfa-gym/lawnmower-v0"""
    overwrite: bool = False
    """replace an existing dataset of that id"""
    incomplete: bool = False
    """export an interrupted recording as it is (its episode ends truncated)"""
    description: str | None = None
    """the dataset's description (default: one naming the run, env and driver)"""
    author: str | None = None
    """the dataset's author"""
    author_email: str | None = None
    """the author's email"""
    code_permalink: str | None = None
    """a link to the code that made the dataset"""

    def run(self) -> int:
        from sfa_gym.export.minari_dataset import export_minari

        dataset = export_minari(
            self.run_path,
            self.dataset_id,
            overwrite=self.overwrite,
            incomplete=self.incomplete,
            description=self.description,
            author=self.author,
            author_email=self.author_email,
            code_permalink=self.code_permalink,
        )
        print(
            f"exported {self.run_path} as the Minari dataset {self.dataset_id!r}: "
            f"{dataset.total_episodes} episode, {dataset.total_steps} steps, in "
            f"{dataset.storage.data_path.parent}"
        )
        return 0
