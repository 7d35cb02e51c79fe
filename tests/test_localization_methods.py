"""Loading feature-method plug-in files by path or built-in name, and building their ``Args``
from JSON-type values."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from sfa_gym.plugins import (
    FeatureMethod,
    PluginError,
    check_views,
    get_capabilities,
    list_plugin_files,
    load_method,
    load_method_plugin,
)

BASELINES = Path(__file__).resolve().parents[1] / "baselines"


def test_every_baseline_loads_and_documents_each_argument():
    files = list_plugin_files(BASELINES)
    assert {p.stem for p in files} == {
        "pca",
        "raw_pixels",
        "band_means",
        "fft_magnitude",
        "sfa",
        "deep_sfa",
        "contrastive",
    }
    views = np.random.default_rng(0).integers(0, 256, size=(12, 40, 350, 3), dtype=np.uint8)
    for path in files:
        factory = load_method_plugin(path)
        assert factory.name == path.stem
        assert load_method_plugin(path.stem).path == path  # the built-in, by name
        arguments = factory.fields()
        assert arguments, f"{path.name} has no Args fields"
        for argument in arguments:
            assert argument.doc, f"{path.name}: field {argument.name} has no docstring"
        method = factory()
        assert isinstance(method, FeatureMethod)
        assert isinstance(get_capabilities(method).regressor, str)
        if path.stem == "sfa":  # trained in test_baselines.py, on a small network
            continue
        if path.stem in ("deep_sfa", "contrastive"):  # trained in test_deep_methods.py
            continue
        assert method.name == path.stem
        features = method.fit(views).transform(views)
        assert features.ndim == 2 and features.shape[0] == 12 and np.all(np.isfinite(features))
        assert method.input_shape_ == (40, 350, 3)


def test_arguments_report_defaults_and_keyword_arguments_reach_the_method():
    factory = load_method_plugin(BASELINES / "band_means.py")
    n_bands = {a.name: a for a in factory.fields()}["n_bands"]
    assert n_bands.default == 8 and n_bands.type == "int" and "bands" in n_bands.doc
    views = np.zeros((2, 40, 350, 3), dtype=np.uint8)
    assert factory(n_bands=4).fit(views).transform(views).shape == (2, 12)
    assert factory.arguments({"n_bands": 4}) == {
        "n_bands": 4,
        "regressor": "quadratic",
        "chunk": 1024,
    }


def test_the_loader_refuses_bad_arguments_naming_the_field_and_the_value():
    factory = load_method_plugin("band_means")
    with pytest.raises(
        ValueError, match=r"band_means\.py: unknown argument 'n_band'; the fields of Args"
    ):
        factory(n_band=4)
    with pytest.raises(ValueError, match=r"argument n_bands must be int, got '4'"):
        factory(n_bands="4")
    with pytest.raises(ValueError, match=r"argument n_bands must be int, got True"):
        factory(n_bands=True)  # JSON true is no count
    with pytest.raises(ValueError, match=r"argument regressor must be str, got 3"):
        load_method("band_means", {"regressor": 3})
    # Literal fields list their choices; JSON lists become tuples; ints are floats where wanted
    with pytest.raises(
        ValueError, match=r"network must be one of \['auto', 'paper_sim', 'paper_outdoor'"
    ):
        load_method("sfa", {"network": "paper"})
    sfa = load_method_plugin("sfa")
    assert sfa.arguments({"node_dim": 16})["node_dim"] == 16
    with pytest.raises(ValueError, match=r"argument node_dim must be int, got 16\.0"):
        sfa.arguments({"node_dim": 16.0})


def test_a_missing_or_unknown_plugin_is_named():
    with pytest.raises(
        FileNotFoundError, match=r"no built-in feature-method 'band_mean'; .*'band_means'"
    ):
        load_method_plugin("band_mean")
    with pytest.raises(FileNotFoundError, match=r"no feature-method file at .*nowhere\.py"):
        load_method("nowhere.py")


def test_a_plugin_with_a_method_class(tmp_path):
    path = tmp_path / "mean_brightness.py"
    path.write_text(
        textwrap.dedent(
            """
            from dataclasses import dataclass
            import numpy as np

            @dataclass(frozen=True)
            class Args:
                scale: float = 1.0
                \"""multiplies the mean\"""

            class METHOD:
                name = "mean_brightness"

                def __init__(self, scale=1.0):
                    self.scale = scale

                def fit(self, views, sequence_ids=None):
                    self.input_shape_ = views.shape[1:]
                    return self

                def transform(self, views):
                    return self.scale * views.mean(axis=(1, 2, 3))[:, None]
            """
        )
    )
    factory = load_method_plugin(path)
    assert [a.name for a in factory.fields()] == ["scale"]
    views = np.full((3, 4, 10, 3), 10, dtype=np.uint8)
    np.testing.assert_allclose(factory(scale=2).fit(views).transform(views), [[20.0]] * 3)
    assert factory().scale == 1.0  # the Args default reaches the class


def test_bad_plugin_files_are_refused_clearly(tmp_path):
    with pytest.raises(FileNotFoundError, match="no feature-method file"):
        load_method_plugin(tmp_path / "missing.py")
    text = tmp_path / "notes.txt"
    text.write_text("x = 1\n")
    with pytest.raises(ValueError, match=r"\.py file"):
        load_method_plugin(text)
    empty = tmp_path / "empty.py"
    empty.write_text("x = 1\n")
    with pytest.raises(PluginError, match="neither make_method"):
        load_method_plugin(empty)
    no_args = tmp_path / "no_args.py"
    no_args.write_text("def make_method(**kwargs):\n    return object()\n")
    with pytest.raises(PluginError, match=r"no_args\.py defines no Args dataclass"):
        load_method_plugin(no_args)
    incomplete = tmp_path / "incomplete.py"
    incomplete.write_text(
        "from dataclasses import dataclass\n@dataclass\nclass Args:\n    pass\n"
        "def make_method(**kwargs):\n    return object()\n"
    )
    with pytest.raises(PluginError, match="not a feature method.*'name', 'fit', 'transform'"):
        load_method_plugin(incomplete)()


def test_files_that_break_the_protocol_get_an_error_naming_the_file(tmp_path):
    broken = tmp_path / "broken.py"
    broken.write_text("import no_such_module_here\n")
    with pytest.raises(PluginError, match=r"broken\.py failed to import.*no_such_module_here"):
        load_method_plugin(broken)
    not_a_dataclass = tmp_path / "loose_args.py"
    not_a_dataclass.write_text(
        "class Args:\n    n: int = 1\n\ndef make_method(**kwargs):\n    return None\n"
    )
    with pytest.raises(PluginError, match=r"loose_args\.py: Args must be a dataclass"):
        load_method_plugin(not_a_dataclass)


def test_args_are_read_from_options_like_the_command_line(capsys):
    factory = load_method_plugin(BASELINES / "fft_magnitude.py")
    views = np.zeros((2, 40, 350, 3), dtype=np.uint8)
    method = factory.from_command_line(["--n-bands", "2", "--n-frequencies", "3"])
    assert method.fit(views).transform(views).shape == (2, 2 * 3 * 3)
    with pytest.raises(SystemExit):
        factory.from_command_line(["--help"])
    text = " ".join(capsys.readouterr().out.split())
    for argument in factory.fields():
        assert "--" + argument.name.replace("_", "-") in text
    # the docstring under the field is its help, in both readings
    doc = {a.name: a.doc for a in factory.fields()}["n_frequencies"]
    assert doc.startswith("lowest DFT frequencies kept per band and channel")
    assert "lowest DFT frequencies kept per band and channel" in text


def test_two_plugins_with_the_same_stem_do_not_clash(tmp_path):
    for folder, value in (("a", 1), ("b", 2)):
        (tmp_path / folder).mkdir()
        (tmp_path / folder / "same.py").write_text(
            "from dataclasses import dataclass\n@dataclass\nclass Args:\n    pass\n"
            "class METHOD:\n"
            "    name = 'same'\n"
            f"    value = {value}\n"
            "    def fit(self, views, sequence_ids=None):\n        return self\n"
            "    def transform(self, views):\n        return views\n"
        )
    first = load_method_plugin(tmp_path / "a" / "same.py")()
    second = load_method_plugin(tmp_path / "b" / "same.py")()
    assert (first.value, second.value) == (1, 2)


def test_check_views_refuses_bad_views():
    with pytest.raises(TypeError, match="uint8"):
        check_views(np.zeros((2, 4, 5, 3)))
    with pytest.raises(ValueError, match=r"one view.*view\[None\]"):
        check_views(np.zeros((4, 5, 3), dtype=np.uint8))
    with pytest.raises(ValueError, match=r"\(N, H, W, 3\)"):
        check_views(np.zeros((2, 4, 5, 4), dtype=np.uint8))
    with pytest.raises(ValueError, match=r"\(N, H, W, 3\)"):
        check_views(np.zeros((0, 4, 5, 3), dtype=np.uint8))


def test_the_library_does_not_import_the_baselines():
    code = (
        "import sys, sfa_gym.localization, sfa_gym.localization.plots, sfa_gym.wrappers\n"
        "scripts = ('baselines', 'eval', 'benchmarks', 'studies')\n"
        "print(sorted(m for m in sys.modules if m.split('.')[0] in scripts))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
