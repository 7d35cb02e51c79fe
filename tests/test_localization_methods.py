"""Loading feature-method plug-in files by path."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from sfa_gym.localization.methods import (
    FeatureMethod,
    PluginError,
    check_views,
    list_method_files,
    load_method_file,
)

BASELINES = Path(__file__).resolve().parents[1] / "baselines"


def test_every_baseline_loads_and_documents_each_argument():
    files = list_method_files(BASELINES)
    assert {p.stem for p in files} >= {"pca", "raw_pixels", "band_means", "fft_magnitude"}
    views = np.random.default_rng(0).integers(0, 256, size=(12, 40, 350, 3), dtype=np.uint8)
    for path in files:
        factory = load_method_file(path)
        assert factory.name == path.stem
        arguments = factory.arguments()
        assert arguments, f"{path.name} has no Args dataclass"
        for argument in arguments:
            assert argument.doc, f"{path.name}: field {argument.name} has no docstring"
        method = factory()
        assert isinstance(method, FeatureMethod)
        assert method.name == path.stem
        features = method.fit(views).transform(views)
        assert features.ndim == 2 and features.shape[0] == 12 and np.all(np.isfinite(features))
        assert method.input_shape_ == (40, 350, 3)
        assert isinstance(method.regressor, str)


def test_arguments_report_defaults_and_keyword_arguments_reach_the_method():
    factory = load_method_file(BASELINES / "band_means.py")
    n_bands = {a.name: a for a in factory.arguments()}["n_bands"]
    assert n_bands.default == 8 and n_bands.type == "int" and "bands" in n_bands.doc
    views = np.zeros((2, 40, 350, 3), dtype=np.uint8)
    assert factory(n_bands=4).fit(views).transform(views).shape == (2, 12)
    with pytest.raises(TypeError, match="n_band"):
        factory(n_band=4)


def test_a_plugin_with_a_method_class(tmp_path):
    path = tmp_path / "mean_brightness.py"
    path.write_text(
        textwrap.dedent(
            """
            import numpy as np

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
    factory = load_method_file(path)
    assert factory.args_type is None and factory.arguments() == []
    views = np.full((3, 4, 10, 3), 10, dtype=np.uint8)
    np.testing.assert_allclose(factory(scale=2.0).fit(views).transform(views), [[20.0]] * 3)


def test_bad_plugin_files_are_refused_clearly(tmp_path):
    with pytest.raises(FileNotFoundError, match="no feature-method file"):
        load_method_file(tmp_path / "missing.py")
    text = tmp_path / "notes.txt"
    text.write_text("x = 1\n")
    with pytest.raises(ValueError, match=r"\.py file"):
        load_method_file(text)
    empty = tmp_path / "empty.py"
    empty.write_text("x = 1\n")
    with pytest.raises(TypeError, match="neither make_method"):
        load_method_file(empty)
    incomplete = tmp_path / "incomplete.py"
    incomplete.write_text("def make_method(**kwargs):\n    return object()\n")
    with pytest.raises(TypeError, match="not a feature method.*'name', 'fit', 'transform'"):
        load_method_file(incomplete)()


def test_files_that_break_the_protocol_get_an_error_naming_the_file(tmp_path):
    broken = tmp_path / "broken.py"
    broken.write_text("import no_such_module_here\n")
    with pytest.raises(PluginError, match=r"broken\.py failed to import.*no_such_module_here"):
        load_method_file(broken)
    not_a_dataclass = tmp_path / "loose_args.py"
    not_a_dataclass.write_text(
        "class Args:\n    n: int = 1\n\ndef make_method(**kwargs):\n    return None\n"
    )
    with pytest.raises(PluginError, match=r"loose_args\.py: Args must be a dataclass"):
        load_method_file(not_a_dataclass)


def test_args_are_read_from_options_like_the_command_line(capsys):
    factory = load_method_file(BASELINES / "fft_magnitude.py")
    views = np.zeros((2, 40, 350, 3), dtype=np.uint8)
    method = factory.from_command_line(["--n-bands", "2", "--n-frequencies", "3"])
    assert method.fit(views).transform(views).shape == (2, 2 * 3 * 3)
    with pytest.raises(SystemExit):
        factory.from_command_line(["--help"])
    text = " ".join(capsys.readouterr().out.split())
    for argument in factory.arguments():
        assert "--" + argument.name.replace("_", "-") in text
    # the docstring under the field is its help, in both readings
    doc = {a.name: a.doc for a in factory.arguments()}["n_frequencies"]
    assert doc.startswith("lowest DFT frequencies kept per band and channel")
    assert "lowest DFT frequencies kept per band and channel" in text


def test_two_plugins_with_the_same_stem_do_not_clash(tmp_path):
    for folder, value in (("a", 1), ("b", 2)):
        (tmp_path / folder).mkdir()
        (tmp_path / folder / "same.py").write_text(
            "class METHOD:\n"
            "    name = 'same'\n"
            f"    value = {value}\n"
            "    def fit(self, views, sequence_ids=None):\n        return self\n"
            "    def transform(self, views):\n        return views\n"
        )
    first = load_method_file(tmp_path / "a" / "same.py")()
    second = load_method_file(tmp_path / "b" / "same.py")()
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
