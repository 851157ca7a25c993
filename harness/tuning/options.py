"""A tune's options (``<out>/tune.json``): how it screens, races and decides, and each unit's
race plan once the race started.

``tune.json`` is read back by ``--analyse`` and by a rerun on the same ``--out``, which
continues the stored race: every key is checked on load (a garbage or mistyped file is one line
naming the file and the key), and the options that define the sequential test (``RACE_KEYS``)
may not change on a rerun.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

from harness.errors import HarnessError

OPTIONS_FILE = "tune.json"
TARGET_GAIN = 0.05  # the gain a default race has 80% power to confirm (issue 35)
RACE_KEYS = (
    "objective",
    "top",
    "block",
    "max_seeds",
    "alpha",
    "target_gain",
    "coarse",
    "groups",
    "exception_seeds",
    "template",
)
# Fresh paired seeds per object on which an object's own best setting is tested against the
# template (chosen, no public source: 80% power for a ~+25-point gain at discordance 0.3 with
# Holm over ~8 objects; a larger --exception-seeds sees smaller gains).
EXCEPTION_SEEDS = 60


@dataclass(frozen=True)
class TuneOptions:
    """How a tune decides (``docs/tune.md``): screening seeds, racers, race blocks, budget."""

    objective: str = "valid"
    screen_seeds: int = 10
    top: int = 3  # challengers raced against the current setting, per unit
    block: int = 20  # fresh seeds per race round
    max_seeds: int | None = None  # fresh seeds per unit at most; None: sized by power
    budget: str | None = None  # "N" race episodes or "Ns" CPU seconds
    alpha: float = 0.05
    sources: dict[str, str] = field(default_factory=dict)  # task name -> its file
    target_gain: float = TARGET_GAIN  # the gain the power-sized race is planned to see
    seconds_each: float = 0.0  # measured screening wall seconds per episode (0: not measured)
    plans: dict[str, dict[str, Any]] = field(default_factory=dict)  # unit key -> its Plan
    coarse: bool = True  # screen every direction coarsely first, then refine the best
    # Template groups (harness.tuning.templates): group name -> its tasks (one object each); a
    # group is raced as one unit over its objects, and its objects' exceptions are tested.
    groups: dict[str, list[str]] = field(default_factory=dict)
    pick_paths: dict[str, str] = field(default_factory=dict)  # task -> its pick block's key path
    exception_seeds: int = EXCEPTION_SEEDS  # fresh paired seeds per object an exception test
    template: bool = False  # pool each task's objects (its object.mesh values) into one template

    @staticmethod
    def load(path: Path) -> TuneOptions:
        """``tune.json``, checked: a garbage or mistyped file is one line naming it and the key."""
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as error:
            raise HarnessError(f"{path}: not a tune's options file ({error})") from None
        if not isinstance(data, dict):
            raise HarnessError(f"{path}: expected a JSON object of tune options")
        known = {f.name: f for f in fields(TuneOptions)}
        data.pop("engine", None)  # written by tunes made while a second (GPU) engine existed
        for key, value in data.items():
            if key not in known:
                raise HarnessError(f"{path}: key {key!r}: not a tune option")
            if not _fits(key, value):
                raise HarnessError(f"{path}: key {key!r}: {value!r} is not a valid value")
        return TuneOptions(**data)


# The types each tune.json key may hold (JSON numbers: int or float).
_TYPES: dict[str, tuple[type, ...]] = {
    "objective": (str,),
    "screen_seeds": (int,),
    "top": (int,),
    "block": (int,),
    "max_seeds": (int, type(None)),
    "budget": (str, type(None)),
    "alpha": (float, int),
    "sources": (dict,),
    "target_gain": (float, int),
    "seconds_each": (float, int),
    "plans": (dict,),
    "coarse": (bool,),
    "groups": (dict,),
    "pick_paths": (dict,),
    "exception_seeds": (int,),
    "template": (bool,),
}
_PLAN_KEYS = {"seeds": int, "block": int, "discordance": (float, int), "rate": (float, int)}


def _fits(key: str, value: Any) -> bool:
    if key in ("coarse", "template"):
        return isinstance(value, bool)
    if isinstance(value, bool) or not isinstance(value, _TYPES[key]):
        return False
    if key in ("groups", "pick_paths") and isinstance(value, dict):
        return all(isinstance(k, str) for k in value) and all(
            isinstance(v, str) or (isinstance(v, list) and all(isinstance(t, str) for t in v))
            for v in value.values()
        )
    if key in ("screen_seeds", "top", "block", "exception_seeds") and value < 1:
        return False
    if key == "max_seeds" and value is not None and value < 1:
        return False
    if key == "alpha" and not 0 < float(value or 0) < 1:
        return False
    if key == "plans" and isinstance(value, dict):
        return all(
            isinstance(p, dict)
            and all(
                isinstance(p.get(k), t) and not isinstance(p.get(k), bool)
                for k, t in _PLAN_KEYS.items()
            )
            and p["seeds"] >= 1
            and p["block"] >= 1
            and isinstance(p.get("challengers", []), list)
            and isinstance(p.get("members", []), list)
            and all(
                isinstance(m, list) and len(m) == 2 and all(isinstance(v, str) for v in m)
                for m in p.get("members", [])
            )
            and all(
                isinstance(c, list) and len(c) == 2 and all(isinstance(v, str) for v in c)
                for c in p.get("challengers", [])
            )
            for p in value.values()
        )
    return True


def stored_options(out: Path) -> TuneOptions | None:
    path = out / OPTIONS_FILE
    return TuneOptions.load(path) if path.is_file() else None


def check_continuation(out: Path, stored: TuneOptions, given: TuneOptions) -> None:
    """Refuse options that would make a continued race a different test."""
    for key in RACE_KEYS:
        before, now = getattr(stored, key), getattr(given, key)
        if before != now and key == "groups":
            raise HarnessError(
                f"the files given group into other templates than the race in {out} was planned "
                f"with ({OPTIONS_FILE} key 'groups': {sorted(before)}, now {sorted(now)}); give "
                "the same files, or a new --out (and --seed) for a new test"
            )
        if before != now:
            flag = "--" + key.replace("_", "-")
            raise HarnessError(
                f"{flag} {now}: the race in {out} was planned with {before} ({OPTIONS_FILE} key "
                f"{key!r}); a rerun continues that sequential test: give the same value, or a new "
                "--out (and --seed) for a new test"
            )
