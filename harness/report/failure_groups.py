"""Failure messages grouped by what they say rather than by their numbers.

Two episodes that failed for the same reason rarely have the same message: IK residuals, line
steps, times and forces differ, and a collision message repeats a body pair once per contact
(``left_link6/banana, left_link6/banana, ...``). ``normalise_message`` turns a message into its
pattern: each list of collision pairs de-duplicated and sorted, millimetre distances bucketed by
decade (a near miss and an unreachable target stay apart), every other number replaced by
``#``. ``group_failures`` counts the failed episodes per robot, arm, failure reason and pattern,
with example episode ids.
"""

from __future__ import annotations

import re

import pandas as pd

GROUP_COLUMNS: tuple[str, ...] = (
    "robot",
    "arm",
    "failure_reason",
    "message_pattern",
    "count",
    "example_episode_ids",
)
NUMBER = "#"
# A body pair as the collision checker names it ("link/other"), and a comma-separated list of them.
_NAME = r"[A-Za-z_][\w.\-]*"
_PAIR = rf"{_NAME}/{_NAME}"
_PAIR_LIST = re.compile(rf"{_PAIR}(?:, {_PAIR})*")
_MILLIMETRES = re.compile(r"(?<![\w.])(\d+(?:\.\d+)?) mm\b")
# A number not glued to a name ("left_link6", "e0000" stay), with thousands separators.
_NUMBER = re.compile(r"(?<![A-Za-z_\d.])(?:\d{1,3}(?:,\d{3})+|\d+)(?:\.\d+)?")
PRIVATE_USE = 0xE000
MM_BUCKETS: tuple[tuple[float, str], ...] = (
    (1.0, "<1 mm"),
    (10.0, "1-10 mm"),
    (100.0, "10-100 mm"),
    (1000.0, "100-1000 mm"),
)


def _mm_bucket(match: re.Match[str]) -> str:
    value = float(match.group(1))
    return next((label for upper, label in MM_BUCKETS if value < upper), ">=1000 mm")


def _unique_pairs(match: re.Match[str]) -> str:
    return ", ".join(sorted(set(match.group(0).split(", "))))


def normalise_message(message: str) -> str:
    """The pattern of a failure message: collision pairs de-duplicated and sorted, millimetres
    bucketed by decade, other numbers replaced by ``#``, whitespace collapsed."""
    text = _PAIR_LIST.sub(_unique_pairs, str(message))
    buckets: list[str] = []

    def hold_bucket(match: re.Match[str]) -> str:
        """A digit-free private-use character stands in for the bucket while numbers go."""
        buckets.append(_mm_bucket(match))
        return chr(PRIVATE_USE + len(buckets) - 1)

    text = _NUMBER.sub(NUMBER, _MILLIMETRES.sub(hold_bucket, text))
    for k, label in enumerate(buckets):
        text = text.replace(chr(PRIVATE_USE + k), label, 1)
    return " ".join(text.split())


def group_failures(df: pd.DataFrame, examples: int = 3) -> pd.DataFrame:
    """Failed episodes counted per (robot, arm, failure_reason, message_pattern).

    ``df`` is a run's episode table (``robot``, ``arm``, ``failure_reason``, ``error_message``,
    ``episode_id``; success rows, whose ``failure_reason`` is empty, are left out). Returns the
    columns ``GROUP_COLUMNS``: ``count`` episodes and ``example_episode_ids``, a list of up to
    ``examples`` ids in the table's order; sorted by robot, arm, then the most frequent first.
    """
    reasons = df["failure_reason"].fillna("").astype(str)
    failed = df.loc[reasons != ""]
    if failed.empty:
        return pd.DataFrame({name: pd.Series(dtype=object) for name in GROUP_COLUMNS})
    messages = failed["error_message"].fillna("").astype(str)
    keyed = pd.DataFrame(
        {
            "robot": failed["robot"].astype(str),
            "arm": failed["arm"].astype(str),
            "failure_reason": failed["failure_reason"].astype(str),
            "message_pattern": messages.map(normalise_message),
            "episode_id": failed["episode_id"].astype(str),
        }
    )
    grouped = keyed.groupby(list(GROUP_COLUMNS[:4]), sort=False)["episode_id"]
    table = grouped.agg(count="size", example_episode_ids=lambda ids: ids.iloc[:examples].tolist())
    table = table.reset_index()
    table = table.sort_values(
        ["robot", "arm", "count", "failure_reason", "message_pattern"],
        ascending=[True, True, False, True, True],
        kind="stable",
    )
    return table.loc[:, list(GROUP_COLUMNS)].reset_index(drop=True)
