"""A template group as one race unit: its pooled screening map, its plan, its objects' table.

The group's objective is the mean valid rate over its objects, each weighted equally. The
screening map of the group (:func:`pooled_map`) averages each setting's rate over the objects
(only settings every object screened); the challengers are its best settings; the race
(:class:`harness.tuning.race.Unit` with ``members``) runs every alive racer on the same seeds of
every object, so the pooled pairs are paired object by object, and with equal seeds per object
their mean difference is the mean over objects of the per-object gains. The exact McNemar test
on those pooled pairs is the stratified paired test with equal weights: conditional on the
discordant pairs it counts each stratum's discordant pairs together, and its variance (the
discordant count) bounds the stratified one from above, so it keeps its level when the objects'
gains differ (it is conservative then).
"""

from __future__ import annotations

import json
import math
from typing import Any

import pandas as pd

from harness.report.frames import column, frame_of
from harness.tuning.analysis import SETTING
from harness.tuning.options import TuneOptions
from harness.tuning.planning import make_plan, screening_discordance

Member = tuple[str, str]  # (task, context): one object of a template


def member_rows(frame: pd.DataFrame, members: list[Member]) -> pd.DataFrame:
    """The rows of ``frame`` (task and context columns) that belong to ``members``."""
    keys = frame["task"].astype(str) + "\t" + frame["context"].astype(str)
    return frame_of(frame[keys.isin([f"{t}\t{c}" for t, c in members])])


def pooled_map(success: pd.DataFrame, members: list[Member]) -> pd.DataFrame:
    """The group's screening map: per setting the objects' mean rate (equal weights), summed
    counts, the earliest grid order; only the settings every member screened."""
    rows = member_rows(success, members).assign(
        member=lambda t: t["task"].astype(str) + "\t" + t["context"].astype(str)
    )
    grouped = rows.groupby(SETTING, sort=False)
    table = grouped.agg(
        objects=("member", "nunique"),
        n=("n", "sum"),
        successes=("successes", "sum"),
        reference_successes=("reference_successes", "sum"),
        fallbacks=("fallbacks", "sum"),
        order=("order", "min"),
        rate=("rate", "mean"),
        reference_rate=("reference_rate", "mean"),
        lo=("lo", "mean"),
        hi=("hi", "mean"),
    ).reset_index()
    table = frame_of(table[column(table, "objects") == len(members)])
    # equal weights: the ranking reads successes; make them the mean rate's share of n
    table["successes"] = (column(table, "rate") * column(table, "n")).round().astype(int)
    first = rows.iloc[0] if len(rows) else None
    for key in ("robot", "arm"):
        table[key] = str(first[key]) if first is not None else ""
    return frame_of(table)


def template_plan(
    success: pd.DataFrame,
    settings: pd.DataFrame,
    members: list[Member],
    current: tuple[str, str],
    chosen: list[tuple[str, str]],
    options: TuneOptions,
) -> dict[str, Any]:
    """The group's race plan, in (object, seed) pairs: sized for ``target_gain`` on the pooled
    rate at the objects' mean screening discordance (or ``max_seeds`` per object), looks at
    least every ``block`` seeds per object, seeds and look spacing rounded up to whole seeds
    per object."""
    count = len(members)
    at = member_rows(success, members)
    at = frame_of(at[(at["approach"] == current[0]) & (at["facing"] == current[1])])
    rate = float(column(at, "rate").mean()) if len(at) else 0.5
    shares = [screening_discordance(settings, m, current, chosen) for m in members]
    shares = [s for s in shares if not math.isnan(s)]
    psi = sum(shares) / len(shares) if shares else math.nan
    pooled = TuneOptions(
        **{
            **options.__dict__,
            "max_seeds": options.max_seeds * count if options.max_seeds else None,
            "block": options.block * count,  # --block and --max-seeds count seeds per object
        }
    )
    plan = make_plan(rate, psi, pooled, len(chosen))
    per_object = math.ceil(plan.seeds / count)
    block = max(1, math.ceil(plan.block / count))
    return {
        "seeds": per_object * count,
        "block": block * count,
        "discordance": plan.discordance,
        "rate": rate,
        "challengers": [list(c) for c in chosen],
        "members": [list(m) for m in members],
    }


def with_template_maps(
    success: pd.DataFrame, units: list[Any], names: dict[tuple[str, str], dict[str, str]]
) -> pd.DataFrame:
    """``success`` with each template unit's pooled map appended under the group's name (its
    ``task``), so the heatmaps, ``success_map.csv`` and the decision rows read a template's map
    as a unit's."""
    extra = []
    for unit in units:
        if not unit.is_template:
            continue
        table = pooled_map(success, list(unit.members))
        table["task"], table["context"] = unit.task, unit.context
        table["object"] = names[(unit.task, unit.context)]["object"]
        extra.append(table.drop(columns=["objects"]))
    if not extra:
        return success
    return frame_of(pd.concat([success, *extra], ignore_index=True))


def object_free(context: str) -> str:
    """A context without its object keys (``object.*``): what the objects of a template share."""
    others = json.loads(context)
    return json.dumps(
        {k: v for k, v in others.items() if not str(k).startswith("object.")}, sort_keys=True
    )


def template_groups(
    success: pd.DataFrame, options: TuneOptions
) -> dict[tuple[str, str], list[Member]]:
    """The template units to race: (group name, shared context) -> its (task, context) members.

    A group of InternDataEngine files (``options.groups``) pools its files' objects; with
    ``options.template`` every other task with several objects (its sweep's ``object.mesh``
    values) is a template of its own, named after the task. Members share their context but for
    the object keys; a template of one member is an ordinary unit (not listed)."""
    tasks, contexts = success["task"].astype(str), success["context"].astype(str)
    pairs = list(dict.fromkeys(zip(tasks, contexts, strict=True)))
    groups: dict[tuple[str, str], list[Member]] = {}
    in_group: set[str] = set()
    for name, tasks in options.groups.items():
        for task, context in pairs:
            if task in tasks:
                groups.setdefault((name, object_free(context)), []).append((task, context))
                in_group.add(task)
    if options.template:
        for task, context in pairs:
            if task not in in_group:
                groups.setdefault((task, object_free(context)), []).append((task, context))
    return {key: members for key, members in groups.items() if len(members) > 1}
