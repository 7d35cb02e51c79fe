"""The command line is generated from the settings dataclasses: every field is an option, with
its docstring as help text."""

from __future__ import annotations

import dataclasses

import pytest

from sfa_gym.cli import main
from sfa_gym.cli.localize import Localize, LocalizeOutdoor, LocalizeRun
from sfa_gym.cli.record import Record


def _options(cls: type) -> list[str]:
    """``--name`` of every field of ``cls``, nested settings dataclasses included (without
    prefix, as the command line spells them)."""
    out = []
    for field in dataclasses.fields(cls):
        if dataclasses.is_dataclass(field.default):
            out += _options(type(field.default))
        elif field.default is True:  # a switch that is on: the option turns it off
            out.append("--no-" + field.name.replace("_", "-"))
        else:
            out.append("--" + field.name.replace("_", "-"))
    return out


def _help(command: str, capsys, monkeypatch) -> str:
    monkeypatch.setenv("COLUMNS", "200")  # one option per line, however long
    with pytest.raises(SystemExit) as exit_:
        main([command, "--help"])
    assert exit_.value.code == 0
    return capsys.readouterr().out


@pytest.mark.parametrize(
    ("command", "cls"),
    [
        ("localize", Localize),
        ("localize-run", LocalizeRun),
        ("localize-outdoor", LocalizeOutdoor),
        ("record", Record),
    ],
)
def test_help_lists_every_field_of_the_settings(command, cls, capsys, monkeypatch):
    text = _help(command, capsys, monkeypatch)
    options = _options(cls)
    assert len(options) > 10
    missing = [o for o in options if o not in text]
    assert not missing, f"sfa-gym {command} --help does not mention {missing}"


def test_help_text_comes_from_the_field_docstrings(capsys, monkeypatch):
    text = _help("localize-run", capsys, monkeypatch)
    assert "every n-th training frame is a training location" in text  # frame_every
    assert "linear SFA dimension and output dimension of every node" in text  # sfa.node_dim
    assert "{layer,rows,none}" in text  # the weight-sharing names


def test_the_old_option_spellings_still_work(tmp_path):
    from sfa_gym.cli.main import parse

    command = parse(
        ["localize", "--out", str(tmp_path), "--env", "sfa_gym/OmniRoverOutdoorCam-v0"]
        + ["--n-outputs", "12", "--weight-sharing", "layer", "--no-baselines", "--quiet"]
    )
    assert isinstance(command, Localize)
    assert command.settings.env_id == "sfa_gym/OmniRoverOutdoorCam-v0"
    assert command.settings.sfa.n_outputs == 12 and command.settings.sfa.weight_sharing == "layer"
    assert command.no_baselines and command.quiet
    run = parse(["localize-run", "--out", str(tmp_path), "--exclude", "0", "1", "0", "1"])
    assert run.settings.exclude == (0.0, 1.0, 0.0, 1.0)
    assert parse(["localize-run", "--out", str(tmp_path), "--no-exclude"]).no_exclude
    assert (
        parse(["localize-run", "--out", str(tmp_path), "--exclude", "None"]).settings.exclude
        is None
    )


def test_a_value_of_the_wrong_type_is_refused_by_the_parser(tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["localize", "--out", str(tmp_path), "--node-dim", "3.5"])
    assert exit_.value.code == 2
    assert "--node-dim" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["localize", "--out", str(tmp_path), "--weight-sharing", "columns"])
