"""The engineering YAML loader: YAML 1.2 numbers, ambiguous forms and duplicate keys refused with
the key named, nesting, aliases and size bounded, no tag executed; and the model file reads
through it."""

from __future__ import annotations

import re

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robocal import Robot
from robocal.core.errors import DataError, ModelError
from robocal.core.yaml_load import MAX_ALIASES, dump_yaml, load_yaml


@pytest.mark.parametrize("text, key", [
    ("d: [0135, 1]", "d[0]"), ("t: 1:30", "t"), ("x: 0x1F", "x"), ("a: {b: [1, 0o17]}", "a.b[1]"),
    ("x: 0b101", "x"), ("x: 1_000", "x"), ("x: 007.5", "x"), ("x: -012", "x"), ("x: 1:30:15.5", "x")])
def test_numbers_that_yaml_versions_read_differently_are_refused_naming_the_key(text, key):
    expected = f"f.yaml: line 1: {re.escape(key)}: '.*' is not a plain decimal"
    with pytest.raises(DataError, match=expected) as err:
        load_yaml(text, "f.yaml")
    assert "\n" not in str(err.value)


def test_yaml_1_2_numbers_booleans_and_texts():
    data = load_yaml("v: [1e-3, .5, -2, +3.0, .inf, -.inf, 1., 0, -0, 0.25, 1E+2]\nn: yes\nf: no\n"
                     "b: [true, False]\nq: '0135'\ne: ~\nw: 12:30 pm", "f.yaml")
    assert data["v"][:4] == [0.001, 0.5, -2, 3.0] and data["v"][4] == float("inf")
    assert data["v"][5:] == [float("-inf"), 1.0, 0, 0, 0.25, 100.0]
    assert isinstance(data["v"][2], int) and isinstance(data["v"][3], float)
    assert data["n"] == "yes" and data["f"] == "no" and data["b"] == [True, False]
    assert data["q"] == "0135" and data["e"] is None and data["w"] == "12:30 pm"


def test_duplicate_keys_are_refused_with_both_lines():
    with pytest.raises(DataError, match=r"line 3: tool.z is given twice \(first on line 2\)"):
        load_yaml("tool:\n  z: 100\n  z: 0\n", "f.yaml")
    assert load_yaml("a: &a {x: 1}\nb:\n  <<: *a\n  x: 2", "f") == {"a": {"x": 1}, "b": {"x": 2}}


def test_depth_aliases_expansion_and_size_are_bounded():
    with pytest.raises(DataError, match="nested deeper than"):
        load_yaml("[" * 1000 + "]" * 1000, "f")
    with pytest.raises(DataError, match="nested deeper than"):
        load_yaml("".join("  " * i + "k:\n" for i in range(200)), "f")
    laughs = "a: &a [x,x,x,x,x,x,x,x,x]\n" + "".join(
        f"{chr(98 + i)}: &{chr(98 + i)} [" + ",".join([f"*{chr(97 + i)}"] * 9) + "]\n" for i in range(8))
    assert len(laughs) < 700
    with pytest.raises(DataError, match=f"more than {MAX_ALIASES} aliases"):
        load_yaml(laughs, "f")
    doubling = "a0: &a0 [x, x]\n" + "".join(f"a{i}: &a{i} [*a{i - 1}, *a{i - 1}]\n" for i in range(1, 31))
    with pytest.raises(DataError, match="once its aliases are expanded"):
        load_yaml(doubling, "f")
    with pytest.raises(DataError, match="refers to the collection it is in"):
        load_yaml("a: &a [1, *a]", "f")
    with pytest.raises(DataError, match="larger than a data file"):
        load_yaml("x: 1\n" * 1_000_000, "f")


def test_no_tag_runs_and_errors_are_one_line(tmp_path):
    marker = tmp_path / "ran"
    for text in (f"k: !!python/object/apply:os.system ['touch {marker}']", "k: !!python/name:os.system",
                 "a: [1, 2", "a: b: c", "{[1]: 2}", "x: 1\n\tbad"):
        with pytest.raises(ModelError) as err:
            load_yaml(text, "m.yaml", ModelError)
        assert "\n" not in str(err.value) and str(err.value).startswith("m.yaml: ")
    assert not marker.exists()


def test_the_model_file_and_the_catalog_read_through_the_loader(tmp_path):
    robot = Robot.from_catalog("abb_irb2600")
    path = tmp_path / "m.yaml"
    robot.save(path)
    text = path.read_text()
    assert Robot.load(path).name == robot.name
    path.write_text(text.replace("units:", "units:\n  angle: rad\nunits:", 1))
    with pytest.raises(ModelError, match=r"m.yaml: line \d+: units is given twice"):
        Robot.load(path)
    path.write_text("units: {length: [mm], angle: deg}\nmdh: {}\n")
    with pytest.raises(ModelError, match="unknown units"):
        Robot.load(path)
    path.write_text("units: {length: mm, angle: deg}\nmdh: {alpha: [0], a: [0], theta: [0], d: [0135]}\n")
    with pytest.raises(ModelError, match=r"mdh.d\[0\]: '0135' is not a plain decimal"):
        Robot.load(path)


_plain = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False) | st.text(max_size=12),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=6), inner, max_size=4),
    max_leaves=20)


@settings(max_examples=150, deadline=None)
@given(_plain)
def test_what_robocal_writes_reads_back_exactly(data):
    assert load_yaml(dump_yaml(data), "f") == data


@pytest.mark.parametrize("path", [("payload_kg",), ("joints", 0, "d"), ("joints", 1, "limits", 0),
                                  ("base", "xyz", 2), ("nominal", "tool.y")])
def test_an_integer_beyond_the_float_range_is_refused_naming_the_field(tmp_path, path):
    """A 401-digit integer in any number field: one ModelError naming the field, never an OverflowError."""
    robot = Robot.from_catalog("abb_irb2600")
    robot.save(tmp_path / "m.yaml")
    data = load_yaml((tmp_path / "m.yaml").read_text(), "model")
    data["payload_kg"] = 12
    node = data
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = int("9" * 401)
    (tmp_path / "big.yaml").write_text(dump_yaml(data))
    with pytest.raises(ModelError, match=r"401 digits") as err:
        Robot.load(tmp_path / "big.yaml")
    assert str(next(k for k in reversed(path) if isinstance(k, str))) in str(err.value)
