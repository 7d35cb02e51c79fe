"""The item-density study changes the counts of the outdoor world's items and nothing else, and
its table shows each density's figures."""

from __future__ import annotations

import dataclasses

from eval.studies.item_density import ITEMS, dense_spec
from eval.tables.study_formatters import item_density_table
from sfa_gym.sim.worlds.spec import load_world_spec


def test_a_density_multiplies_every_item_count_and_nothing_else():
    shipped = load_world_spec("paper_outdoor")
    assert dense_spec(1.0) == shipped
    dense = dense_spec(2.5)
    for kind in ITEMS:
        before, after = getattr(shipped.outdoor, kind), getattr(dense.outdoor, kind)
        assert after.count == round(before.count * 2.5) and after.count > before.count
        assert dataclasses.replace(after, count=before.count) == before
    unchanged = {kind: getattr(shipped.outdoor, kind) for kind in ITEMS}
    assert dataclasses.replace(dense.outdoor, **unchanged) == shipped.outdoor
    assert dataclasses.replace(dense, outdoor=shipped.outdoor) == shipped


def test_the_table_shows_each_density_with_its_interval():
    entry = {"mean": 1.3, "interval": [1.2, 1.4]}
    rows = {
        "1": {"alpha": entry, "alpha_sharp": entry, "contrast_median": 0.28, "step_ratio": 1.0},
        "3": {
            "alpha": {"mean": 1.25, "interval": None},
            "alpha_sharp": entry,
            "contrast_median": 0.3,
            "step_ratio": 1.4,
        },
    }
    lines = item_density_table([{"rows": rows}], {}).splitlines()
    assert lines[2] == "| x 1 | 1.30 [1.20, 1.40] | 1.30 [1.20, 1.40] | 0.280 | 1.00 |"
    assert lines[3] == "| x 3 | 1.25 | 1.30 [1.20, 1.40] | 0.300 | 1.40 |"
