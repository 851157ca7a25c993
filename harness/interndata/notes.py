"""What a run takes from an InternData file: printed, and kept in the run directory."""

from __future__ import annotations

from pathlib import Path

from harness.interndata.result import InternDataPick

NOTES_FILE = "skipped.txt"


def summary_lines(path: str | Path, picks: list[InternDataPick]) -> list[str]:
    """What the run takes from an InternData file: its picks, then the skills it skips."""
    lines = [f"InternDataEngine file {path}: {len(picks)} pick skill(s), each run as a task"]
    for pick in picks:
        objects = ", ".join(obj.name for obj in pick.task.objects)
        lines.append(
            f"  {pick.task.name}: {pick.key} -> {pick.robot} {pick.arm}, picks "
            f"{pick.task.target_object.name!r} (scene: {objects})"
        )
    skipped = picks[0].skipped_skills if picks else ()
    if skipped:
        lines.append(f"skipped {len(skipped)} skill(s) (pick-harness runs pick skills only):")
        lines.extend(f"  {skill.describe()}" for skill in skipped)
    return lines


def note_lines(path: str | Path, picks: list[InternDataPick]) -> list[str]:
    """The summary plus every note of the mapping (skipped skills, ignored keys), per task."""
    lines = summary_lines(path, picks)
    for pick in picks:
        lines += ["", f"notes for {pick.task.name} ({pick.key}):"]
        lines += [f"  {note}" for note in pick.skipped] or ["  none"]
    return lines


def write_notes(run_dir: Path, lines: list[str]) -> Path:
    """``RUN_DIR/skipped.txt`` with the given note lines."""
    out = run_dir / NOTES_FILE
    from harness.writes import write_file

    return write_file(out, "\n".join(lines) + "\n", root=run_dir)
