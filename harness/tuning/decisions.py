"""The tune's decisions as tables: one row per unit (``decisions.csv``), one per task file.

Per unit (robot, arm, object) the verdict with its evidence from the race's fresh seeds only:
the chosen (or current) setting's rate with its exact (Clopper-Pearson) 95% interval, the
reference rate beside it, the paired gain over the current setting with its Newcombe interval,
the exact p-value and the Holm level of the look that confirmed it, the gain its seeds could
see at 80% power, and the screening rate for context (never the evidence). Per task file the
units (its objects) are pooled only when they agree: every object switches to the same
setting, or every object keeps the current one; otherwise the file keeps its setting and the
disagreement is said.
"""

from __future__ import annotations

import json
from typing import Any

import pandas as pd

from harness.report.frames import series_rows
from harness.tuning.analysis import filter_label, isolated
from harness.tuning.causes import cause_sentence
from harness.tuning.decide import (
    KEEP,
    NO_SETTING_HELPS,
    SWITCH,
    UNDECIDED,
    Racer,
    gain_interval,
    verdict,
)
from harness.tuning.intervals import exact_interval
from harness.tuning.race import Unit


def setting_label(setting: tuple[str, str]) -> str:
    return f"approach {filter_label(setting[0])} / facing {filter_label(setting[1])}"


def _rates(racer: Racer, prefix: str, n: int | None = None) -> dict[str, Any]:
    outcomes, reference = racer.outcomes[:n], racer.reference[:n]
    k, total = int(sum(outcomes)), len(outcomes)
    lo, hi = exact_interval(k, total) if total else (float("nan"), float("nan"))
    return {
        f"{prefix}n": total,
        f"{prefix}successes": k,
        f"{prefix}rate": k / total if total else float("nan"),
        f"{prefix}lo": lo,
        f"{prefix}hi": hi,
        f"{prefix}reference_rate": sum(reference) / total if total else float("nan"),
    }


def unit_row(
    unit: Unit, unit_map: pd.DataFrame, names: dict[str, str], why: str, objective: str = "valid"
) -> dict[str, Any]:
    """The decision row of one unit (``names``: robot, arm, object)."""
    race = unit.race
    decided = verdict(race, why)
    current = race.current
    shown = decided.chosen or current
    n = min(len(shown.outcomes), len(current.outcomes))
    screen = {
        (str(a), str(f)): r
        for a, f, r in zip(unit_map["approach"], unit_map["facing"], unit_map["rate"], strict=True)
    }
    low, high = gain_interval(shown, current) if decided.chosen else (0.0, 0.0)
    won = sum(a and not b for a, b in zip(shown.outcomes, current.outcomes, strict=False))
    lost = sum(b and not a for a, b in zip(shown.outcomes, current.outcomes, strict=False))
    contenders = "; ".join(
        f"{setting_label(r.setting)} ({r.successes}/{len(r.outcomes)})" for r in decided.contenders
    )
    return {
        **names,
        "task": unit.task,
        "context": unit.context,
        "verdict": decided.verdict,
        "approach": shown.setting[0],
        "facing": shown.setting[1],
        "setting": setting_label(shown.setting),
        **_rates(shown, "", n),
        "current_approach": current.setting[0],
        "current_facing": current.setting[1],
        **_rates(current, "current_", n),
        "gain": (won - lost) / n if n else 0.0,
        "gain_lo": low,
        "gain_hi": high,
        "only_new": won,
        "only_current": lost,
        "p_holm": shown.p_value if decided.chosen else float("nan"),
        "level": shown.level if decided.chosen else float("nan"),
        "confirmed_at_look": shown.confirmed_at if decided.chosen else None,
        "screen_rate": screen.get(shown.setting, float("nan")),
        "current_screen_rate": screen.get(current.setting, float("nan")),
        "isolated": bool(decided.chosen) and isolated(unit_map, shown.setting),
        "racers": len(race.racers),
        "looks": race.look,
        "contenders": contenders,
        "seeds_needed": decided.seeds_needed,
        "seeds_needed_in_plan": decided.within_plan,
        "planned_seeds": race.plan.seeds,
        "planned_looks": race.plan.looks,
        "look_every": race.plan.block,
        "detectable_gain": decided.detectable,
        "best_rate_hi": max(_rates(r, "")["hi"] for r in race.racers if r.outcomes)
        if any(r.outcomes for r in race.racers)
        else float("nan"),
        "cause": cause_sentence(unit.rows, objective)
        if decided.verdict == NO_SETTING_HELPS
        else "",
        "reason": decided.reason,
    }


def race_rows(units: list[Unit]) -> pd.DataFrame:
    """``race.csv``: every racer of every unit, its fresh seeds and when it was dropped."""
    rows = []
    for unit in units:
        for racer in unit.race.racers:
            rows.append(
                {
                    "task": unit.task,
                    "context": unit.context,
                    "setting": setting_label(racer.setting),
                    "current": racer is unit.race.current,
                    "screen_rank": racer.rank,
                    "n": len(racer.outcomes),
                    "successes": racer.successes,
                    "fallback": racer.fallback,
                    "confirmed_at_look": racer.confirmed_at,
                    "dropped_at_look": racer.dropped_at,
                }
            )
    return pd.DataFrame(rows)


def file_decision(rows: pd.DataFrame) -> dict[str, Any]:
    """One task's decision over its objects (``rows``: its unit rows)."""
    verdicts = set(rows["verdict"])
    settings = {(str(a), str(f)) for a, f in zip(rows["approach"], rows["facing"], strict=True)}
    first = rows.iloc[0]
    current = (str(first["current_approach"]), str(first["current_facing"]))
    if verdicts == {SWITCH} and len(settings) == 1:
        return {"verdict": SWITCH, "setting": settings.pop(), "agree": True}
    if verdicts == {KEEP}:
        return {"verdict": KEEP, "setting": current, "agree": True}
    if verdicts == {UNDECIDED}:
        return {"verdict": UNDECIDED, "setting": current, "agree": True}
    if verdicts == {NO_SETTING_HELPS}:
        return {"verdict": NO_SETTING_HELPS, "setting": current, "agree": True}
    if UNDECIDED in verdicts:  # an object's race decided nothing: nothing pooled, nothing written
        return {"verdict": UNDECIDED, "setting": current, "agree": False}
    return {"verdict": KEEP, "setting": current, "agree": False}


def object_name(context: str, fallback: str) -> str:
    """The object a unit's context names (its ``object.mesh`` value), else the row's object."""
    others = json.loads(context)
    return str(others.get("object.mesh", fallback)) if isinstance(others, dict) else fallback


def _seen(row: Any) -> str:
    gain = float(row["detectable_gain"])
    if gain != gain or gain == float("inf"):
        return "its seeds could confirm no gain at 80% power"
    return (
        f"its {row['current_n']} seeds see a gain of {gain * 100:+.0f} points or more at 80% power"
    )


def verdict_line(row: Any) -> str:
    """One unit's decision as a sentence."""
    head = f"{row['robot']} {row['arm']} {row['object']}: "
    current = f"current {row['current_successes']}/{row['current_n']}"
    if row["verdict"] == SWITCH:
        flag = " (isolated: every grid neighbour screened much worse)" if row["isolated"] else ""
        return (
            f"{head}switch to {row['setting']}: {row['successes']}/{row['n']} = "
            f"{row['rate']:.0%} (95% CI {row['lo']:.2f}-{row['hi']:.2f}) vs {current} = "
            f"{row['current_rate']:.0%} on fresh seeds; gain {row['gain']:+.0%} (95% CI "
            f"{row['gain_lo']:+.2f} to {row['gain_hi']:+.2f}), exact McNemar p = "
            f"{row['p_holm']:.2g} <= {row['level']:.2g} "
            f"(look {int(row['confirmed_at_look'])}'s Holm level){flag}"
        )
    if row["verdict"] == NO_SETTING_HELPS:
        return (
            f"{head}no setting helps: every raced setting's 95% upper bound is below 10% "
            f"(best {row['best_rate_hi']:.2f}; {current}); {row['cause'] or 'no failure recorded'}"
        )
    if row["verdict"] == UNDECIDED:
        contenders = f"contenders {row['contenders']}" if row["contenders"] else "no contender"
        if not row["contenders"]:
            settle = ""
        elif row["seeds_needed_in_plan"]:
            settle = (
                f"; about {row['seeds_needed']} paired seeds of this plan would settle it (run "
                "again with the same --out and a larger --budget: the race continues)"
            )
        else:
            settle = (
                f"; this plan's {row['planned_seeds']} seeds have under 80% power at the gain "
                f"seen: about {row['seeds_needed']} paired seeds in a new test (new --out, --seed)"
            )
        return (
            f"{head}undecided ({row['reason']}; {row['current_n']} fresh seeds; {current}); "
            f"{contenders}; {_seen(row)}{settle}"
        )
    return (
        f"{head}keep current: {current} = {row['current_rate']:.0%} (95% CI "
        f"{row['current_lo']:.2f}-{row['current_hi']:.2f}) on fresh seeds; no setting "
        f"confirmed better ({row['reason']}); {_seen(row)}"
    )


def lines(decisions: pd.DataFrame) -> list[str]:
    return [verdict_line(row) for row in series_rows(decisions)]
