"""The paper-pipeline study's summary and its generated table (the runs themselves are the
study's: ``python -m eval.studies.paper_pipeline``)."""

from __future__ import annotations

import pytest

from eval.studies.paper_pipeline import ROWS, Args, main, summarise
from eval.tables.study_formatters import paper_pipeline_table


def test_summary_is_the_mean_over_worlds_with_a_t_interval_from_three_worlds():
    runs = [
        {"linear": [2.0, 3.0], "quadratic": [1.0, 1.0]},
        {"linear": [3.0, 3.0], "quadratic": [1.0, 2.0]},
        {"linear": [4.0, 3.0], "quadratic": [1.0, 3.0]},
    ]
    found = summarise(runs)
    x, y = found["linear"]
    assert x["mean"] == 3.0 and y["mean"] == 3.0
    # 3.0 +- t(0.975, 2) * 1 / sqrt(3) = 3.0 +- 2.484
    assert x["interval"] == pytest.approx([0.5159, 5.4841], abs=1e-4)
    assert y["interval"] == [3.0, 3.0]  # equal values: the point interval
    assert summarise(runs[:2])["quadratic"][1] == {"mean": 1.5, "interval": None}


def test_table_rows_come_from_the_file():
    entry = {"mean": 2.5, "interval": [2.0, 3.0]}
    data = {
        "paper_mae_percent": [1.83, 1.68],
        "rows": {
            "reference": {
                "change": "what changes",
                "linear": [entry, {"mean": 3.25, "interval": None}],
                "quadratic": [entry, entry],
            }
        },
    }
    lines = paper_pipeline_table([data], {}).splitlines()
    assert lines[2] == "| paper | Metka et al. 2013 | 1.83 | 1.68 | - | - |"
    assert lines[3] == (
        "| `reference` | what changes | 2.50 [2.00, 3.00] | 3.25 | 2.50 [2.00, 3.00] "
        "| 2.50 [2.00, 3.00] |"
    )


def test_unknown_rows_are_refused_by_name(tmp_path):
    with pytest.raises(SystemExit, match="unknown rows \\['nope'\\]"):
        main(Args(rows=("nope",), json=tmp_path / "x.json"))
    assert "reference" in ROWS


def test_merge_refuses_a_file_of_other_worlds(tmp_path):
    import json

    path = tmp_path / "pp.json"
    path.write_text(json.dumps({"world_seeds": [0, 1, 2], "rows": {}}))
    with pytest.raises(SystemExit, match=r"holds world seeds \[0, 1, 2\], this run \[5\]"):
        main(Args(rows=("reference",), world_seeds=(5,), json=path, merge=True))


def test_merge_keeps_the_other_rows_in_the_order_of_rows(tmp_path, monkeypatch):
    import json

    import eval.studies.paper_pipeline as study

    path = tmp_path / "pp.json"
    kept = {name: {"change": f"kept {name}"} for name in ("raster", "outputs_4")}
    path.write_text(json.dumps({"world_seeds": [0], "rows": kept}))
    monkeypatch.setattr(study, "RunCache", lambda cache: None)
    fake = {"world_seed": 0, "linear": [2.0, 3.0], "quadratic": [1.0, 1.0], "seconds": 0.0}
    monkeypatch.setattr(study, "run_row", lambda name, seed, runs: fake)
    result = main(Args(rows=("reference", "raster"), world_seeds=(0,), json=path, merge=True))
    assert list(result["rows"]) == [n for n in ROWS if n in ("reference", "raster", "outputs_4")]
    assert result["rows"]["outputs_4"] == kept["outputs_4"]  # not run: kept as it was
    assert result["rows"]["raster"]["runs"] == [fake]  # run again: replaced
    assert json.loads(path.read_text())["rows"] == result["rows"]
