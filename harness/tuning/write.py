"""``harness tune ... --write DIR``: per tuned task file, a copy with only its filter keys changed.

The copy is the file read and written by ruamel.yaml's round-trip mode, so every other key,
comment, order and quoting stays (``semantics: strict`` and ``timing: ruckig`` stay strict and
ruckig); an existing filter list is edited in place (its comments stay), a new key is appended
to the pick block, a key whose tuned value is "no filter" is removed. Beside each copy
``<name>.diff`` is the unified diff against the original.
"""

from __future__ import annotations

import difflib
import io
from pathlib import Path
from typing import Any

from ruamel.yaml import YAML
from ruamel.yaml.comments import CommentedMap, CommentedSeq
from ruamel.yaml.util import load_yaml_guess_indent

from harness.config.line_edit import parse_key_path, set_values
from harness.errors import HarnessError
from harness.files import MAX_CONFIG_BYTES, read_capped, safe_file_name
from harness.writes import check_target, write_file


def _flow(values: list[Any]) -> CommentedSeq:
    seq = CommentedSeq(values)
    seq.fa.set_flow_style()
    return seq


def merged_text(text: str, keys: dict[str, list[Any] | None], source: Path) -> str:
    """``text`` (a task file) with the pick keys of ``keys`` set (None: removed)."""
    data = YAML().load(text)
    if isinstance(data, CommentedMap) and isinstance(data.get("pick"), CommentedMap):
        return set_values(text, {("pick",): keys}, str(source))  # only the filter lines change
    yaml = YAML()
    yaml.preserve_quotes = True
    yaml.width = 4096
    try:
        _, indent, sequence_offset = load_yaml_guess_indent(text)
    except IndexError:  # ruamel's guess fails on some layouts: its defaults then
        indent, sequence_offset = 2, 0
    yaml.indent(mapping=sequence_offset or indent, sequence=indent, offset=sequence_offset)
    data = yaml.load(text)
    if not isinstance(data, CommentedMap):
        raise HarnessError(f"{source}: not a task file (a mapping)")
    pick = data.get("pick")
    if pick is None:
        pick = data["pick"] = CommentedMap()
    if not isinstance(pick, CommentedMap):
        raise HarnessError(f"{source}: key pick: expected a mapping")
    for key, value in keys.items():
        old = pick.get(key)
        if value is None:
            pick.pop(key, None)
        elif isinstance(old, CommentedSeq):
            del old[:]
            old.extend(value)
        else:
            pick[key] = _flow(value)
    out = io.StringIO()
    yaml.dump(data, out)
    return out.getvalue()


def write_copy(
    source: Path,
    keys: dict[str, list[Any] | None],
    out_dir: Path,
    pick_path: str | None = None,
) -> tuple[Path, Path]:
    """Write ``out_dir/<source name>`` (merged) and ``<source name>.diff``; their paths.

    ``pick_path``: the key path of the pick block in an InternDataEngine file
    (``tasks[0].skills[0].franka[0].left[0]``); its filter lines are edited in place
    (:mod:`harness.config.line_edit`), so the copy differs from the file only in them. A harness
    task file's ``pick`` block is edited the same way when it has one."""
    text = read_capped(source, MAX_CONFIG_BYTES).decode("utf-8")  # never blocks on a FIFO
    if pick_path is not None:
        merged = set_values(text, {parse_key_path(pick_path): keys}, str(source))
    else:
        merged = merged_text(text, keys, source)
    target = out_dir / safe_file_name(source.name)
    diff_path = out_dir / safe_file_name(source.name, ".diff")
    check_target(target)  # both refused before either is written
    check_target(diff_path)
    write_file(target, merged, root=out_dir)
    diff = difflib.unified_diff(
        text.splitlines(keepends=True),
        merged.splitlines(keepends=True),
        fromfile=str(source),
        tofile=str(target),
    )
    write_file(diff_path, "".join(diff), root=out_dir)
    return target, diff_path
