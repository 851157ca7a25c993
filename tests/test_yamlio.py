"""YAML loading with line numbers: key paths, merges, duplicates, aliases, pathological input."""

from __future__ import annotations

import datetime

import pytest
import yaml

from harness.config import ConfigError, parse_text, read_yaml
from harness.config.yamlio import MAX_NODES, format_key_path, parse_yaml

TEXT = """\
robot: fr3
objects:
  - name: cube
    mesh: cube
  -
    name: ball
    mass: 0.2
pick:
  filter_z_dir: [downward, 140]
  nested:
    deeper: 1
"""


def test_every_key_path_gets_its_line() -> None:
    doc = parse_yaml(TEXT)
    assert doc.data["objects"][1] == {"name": "ball", "mass": 0.2}
    assert doc.line_of(()) == 1
    assert doc.line_of(("robot",)) == 1
    assert doc.line_of(("objects",)) == 2
    assert doc.line_of(("objects", 0)) == 3
    assert doc.line_of(("objects", 1)) == 6
    assert doc.line_of(("objects", 0, "mesh")) == 4
    # A list item whose mapping starts on the line after the dash.
    assert doc.line_of(("objects", 1, "name")) == 6
    assert doc.line_of(("objects", 1, "mass")) == 7
    assert doc.line_of(("pick", "filter_z_dir")) == 9
    assert doc.line_of(("pick", "filter_z_dir", 1)) == 9
    assert doc.line_of(("pick", "nested", "deeper")) == 11


def test_line_of_falls_back_to_the_longest_known_prefix() -> None:
    doc = parse_yaml(TEXT)
    # Absent key: the item's line (a block mapping item starts at its first key, after the dash).
    assert doc.line_of(("objects", 1, "friction")) == 6
    assert doc.line_of(("pick", "absent", "deeper")) == 8
    assert doc.line_of(("nowhere",)) == 1  # the document itself


def test_scalars_resolve_like_safe_load() -> None:
    text = "i: 3\nf: 0.5\nb: true\nn: null\ns: 'x'\nbig: 1e3\nnan: .nan\nd: 2024-01-02\n"
    data = parse_yaml(text).data
    assert data == yaml.safe_load(text) | {"nan": data["nan"]}
    assert data["big"] == "1e3"  # YAML 1.1: no dot, so a string (as safe_load)
    assert data["nan"] != data["nan"]
    assert data["d"] == datetime.date(2024, 1, 2)


def test_empty_document_is_none() -> None:
    assert parse_yaml("").data is None
    assert parse_yaml("# only a comment\n").data is None


def test_merge_keys_expand_and_explicit_keys_win() -> None:
    text = "base: &b\n  x: 1\n  y: 2\nc:\n  <<: *b\n  y: 5\n"
    doc = parse_yaml(text)
    assert doc.data["c"] == {"x": 1, "y": 5}
    assert doc.data == yaml.safe_load(text)
    assert doc.line_of(("c", "y")) == 6  # the explicit key, not the anchor's
    assert doc.line_of(("c", "x")) == 2  # merged keys point at their definition


def test_merge_of_a_list_of_mappings() -> None:
    text = "a: &a {x: 1}\nb: &b {y: 2}\nc:\n  <<: [*a, *b]\n  z: 3\n"
    assert parse_yaml(text).data["c"] == {"x": 1, "y": 2, "z": 3}


def test_duplicate_keys_are_errors_with_both_lines() -> None:
    with pytest.raises(ConfigError) as info:
        parse_text("robot: fr3\narm: left\nrobot: lift2\n", "t.yaml")
    assert info.value.line == 3
    assert (
        info.value.one_line() == "t.yaml:3: invalid YAML: duplicate key 'robot' (first on line 1)"
    )


def test_duplicate_keys_nested() -> None:
    with pytest.raises(ConfigError, match=r"t.yaml:4: .*duplicate key 'mass' \(first on line 3\)"):
        parse_text("objects:\n  - name: a\n    mass: 1\n    mass: 2\n", "t.yaml")


def test_recursive_alias_is_an_error_not_a_crash() -> None:
    for text in ("a: &a [*a]\n", "a: &a {b: *a}\n"):
        with pytest.raises(ConfigError, match="recursive alias"):
            parse_text(text, "t.yaml")


def test_shared_alias_is_fine() -> None:
    assert parse_yaml("a: &a [1, 2]\nb: [*a, *a]\n").data["b"] == [[1, 2], [1, 2]]


def test_alias_bomb_is_cut_off() -> None:
    text = "a: &a [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]\n"
    previous = "a"
    for level in range(8):  # 10**9 nodes if expanded
        text += f"l{level}: &l{level} [" + ", ".join([f"*{previous}"] * 10) + "]\n"
        previous = f"l{level}"
    with pytest.raises(ConfigError, match=f"more than {MAX_NODES} nodes"):
        parse_text(text, "bomb.yaml")


def test_collection_keys_are_errors() -> None:
    with pytest.raises(ConfigError, match=r"t\.yaml:1: invalid YAML: mapping keys must be scalars"):
        parse_text("? [1]\n: 2\n", "t.yaml")


@pytest.mark.parametrize(
    ("text", "line", "problem"),
    [
        ("a: [1, 2\nb: 3\n", 2, "expected ',' or ']'"),
        ("a:\n\t- 1\n", 2, "found character '\\t' that cannot start any token"),
        ("a: 1\n---\nb: 2\n", 2, "expected a single document"),
        ("a: !!python/object:os.system x\n", 1, "unsupported YAML tag"),
        ("a: *missing\n", 1, "found undefined alias"),
        ("a: 'unterminated\n", 2, "found unexpected end of stream"),
    ],
)
def test_syntax_errors_are_located(text: str, line: int, problem: str) -> None:
    with pytest.raises(ConfigError) as info:
        parse_text(text, "bad.yaml")
    assert info.value.line == line
    assert info.value.file == "bad.yaml"
    assert problem in info.value.message
    assert info.value.one_line().startswith(f"bad.yaml:{line}: invalid YAML: ")


def test_deep_nesting_is_an_error_not_a_crash() -> None:
    with pytest.raises(ConfigError, match="invalid YAML"):
        parse_text("[" * 5000 + "]" * 5000, "deep.yaml")


def test_read_yaml_file_problems(tmp_path) -> None:
    with pytest.raises(ConfigError, match="file not found") as info:
        read_yaml(tmp_path / "absent.yaml")
    assert info.value.file.endswith("absent.yaml")
    binary = tmp_path / "binary.yaml"
    binary.write_bytes(b"\xff\xfe\x00garbage")
    with pytest.raises(ConfigError, match="cannot read file"):
        read_yaml(binary)
    with pytest.raises(ConfigError, match="cannot read file"):
        read_yaml(tmp_path)  # a directory


def test_format_key_path() -> None:
    assert format_key_path(()) == "<root>"
    assert format_key_path(("objects", 0, "mass")) == "objects[0].mass"
    assert format_key_path(("axes", "pick.filter_z_dir")) == "axes.pick.filter_z_dir"
    assert format_key_path(("pick", "filter_z_dir", 1)) == "pick.filter_z_dir[1]"
