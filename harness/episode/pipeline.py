"""One pick episode: scene reset, candidate selection, feasibility, plan, execution, verdict.

``run_episode(spec, scene_cache)`` never raises for episode-level problems: every outcome is one
flat row (``EpisodeResult.row``, the columns of ``harness.row.EpisodeRow``) with ``success`` and
a ``failure_reason`` from the taxonomy (``harness.failures``):

``filter_empty`` (no candidate at all), ``no_feasible_candidate`` (strict: none passed the
feasibility test), ``plan_failed`` (the executed motion could not be planned or timed),
``collision`` (strict), ``no_contact``, ``dropped``, ``lift_below_threshold``,
``velocity_invalid``, ``sim_unstable`` (NaN or MuJoCo warnings), ``timeout`` (the episode
length limit), ``error`` (an exception, with its message).

Timeline (the reference's, section 7 and quirks 6 and 7): reset and place; one reference step
(1/30 s) of physics; record the target's ``obj_init_trans`` (the lift reference); settle 20
steps; choose and test the grasp from the object pose at that moment; plan; 10 warm-up steps
with the robot holding still; execute. ``max_episode_length`` counts the execution's control
steps only, as the reference's loop does.

Randomness: one independent stream per purpose, derived from ``spec.seed``
(``harness.episode.streams``): the scene reset, the candidate draw, the lift offset, and per
annotated grasp its feasibility test and its executed plan -- same spec, same row. A candidate's
verdict and executed outcome therefore depend only on (task physics, seed, candidate), which lets
points that differ only in their selection keys share them (``harness.episode.candidate_cache``;
pass a ``CandidateCache`` to ``run_episode``). An episode that used any shared evaluation carries no
trace (``EpisodeResult.trace`` is None); run it without the cache to get one (same row).

Row columns: each stage appends typed records (``harness.episode.records``: dataclasses whose
fields are ``EpisodeRow`` columns) and ``run_episode`` merges them into the row in one place,
in the order they were produced; the seed's shared evaluations are read and filled through
``harness.episode.evaluation.SeedEvaluation``.

The per-step record (``EpisodeResult.trace``) carries what a viewer needs: joint and object
trajectories, TCP poses, gripper width, finger forces, phases and events, every candidate with
its verdict, and the planned and executed TCP paths.

A handover's second pick (``TaskConfig.handover``) runs its phases instead
(``harness.episode.handover``: the first pick and goto, then this pick from mid-air), on the
same stages, without the candidate cache.

Scenes are cached per worker in ``scene_cache`` (any dict), keyed by (robot, objects, physics):
an episode on a cached scene only resets arrays.
"""

from __future__ import annotations

import json
import time
import traceback
from typing import Any

import mujoco

from harness.episode.candidate_cache import CandidateCache, evaluation_key
from harness.episode.evaluation import SeedEvaluation
from harness.episode.execution import execute_chosen
from harness.episode.handover import run_handover
from harness.episode.planning import candidates, feasibility
from harness.episode.records import EndColumns, RowRecord, WallTimeColumns, merge_records
from harness.episode.result import EpisodeResult
from harness.episode.setup import EpisodeStopError, reset
from harness.episode.spec import EpisodeSpec
from harness.errors import EpisodeTimeoutError, HarnessError
from harness.pick.outcome import ValidityColumns
from harness.pick.validity import validity_enabled
from harness.row import IDENTITY_COLUMNS, EpisodeRow, identity_columns
from harness.version import __version__

__all__ = ["base_row", "run_episode"]  # the package __init__ exports the rest from their modules


# --------------------------------------------------------------------------------------------
# Row


def base_row(spec: EpisodeSpec) -> dict[str, Any]:
    """The identity and configuration columns of an episode's row."""
    pick = spec.task.pick

    def filt(value: Any) -> str:
        return "" if value is None else json.dumps(value.as_list())

    identity = identity_columns(spec)
    row = EpisodeRow(
        **{name: identity[name] for name in IDENTITY_COLUMNS},
        semantics=pick.semantics,
        test_mode=pick.test_mode,
        timing=pick.timing,
        filter_x_dir=filt(pick.filter_x_dir),
        filter_y_dir=filt(pick.filter_y_dir),
        filter_z_dir=filt(pick.filter_z_dir),
        approach_filter=filt(pick.approach_filter),
        facing_filter=filt(pick.facing_filter),
        direction_to_obj=pick.direction_to_obj or "",
        pre_grasp_offset=pick.pre_grasp_offset,
        harness_version=__version__,
        mujoco_version=mujoco.__version__,
    ).as_dict()
    row.update(identity)  # the param.* columns follow the fixed ones
    return row


# --------------------------------------------------------------------------------------------
# The episode


def run_episode(
    spec: EpisodeSpec,
    scene_cache: dict[Any, Any] | None = None,
    candidate_cache: CandidateCache | None = None,
) -> EpisodeResult:
    """Run one episode; exceptions become ``error`` rows (see the module docstring).

    With ``candidate_cache`` the episode reuses (and adds to) the evaluations of earlier
    episodes with the same task physics and seed; its row is the same as without, and it has a
    trace only when it computed everything itself.
    """
    wall_start = time.perf_counter()
    row = base_row(spec)
    result = EpisodeResult(spec=spec, row=row)
    if candidate_cache is None:
        evaluation = SeedEvaluation()
    else:
        key = evaluation_key(spec.task, spec.seed)
        evaluation = SeedEvaluation(candidate_cache.memory(key), key)
    records: list[RowRecord] = []
    try:
        _run(spec, scene_cache, result, evaluation, records)
        failure, message = "", ""
    except EpisodeStopError as stop:
        failure, message = stop.reason, stop.message
        if stop.where is not None:
            records.append(stop.where)
    except EpisodeTimeoutError as exc:  # harness.sim.budget: the run's limits, not an error
        failure, message = "timeout", str(exc)
    except HarnessError as exc:
        failure, message = "error", str(exc)
    except Exception as exc:  # any bug or library failure must not lose the episode
        where = traceback.extract_tb(exc.__traceback__)[-1]
        failure = "error"
        message = (
            f"{type(exc).__name__}: {exc} (at {where.filename.rsplit('/', 1)[-1]}:{where.lineno})"
        )
    records.append(EndColumns(failure, message, success=failure == ""))
    merge_records(row, records)  # the one place the stages' columns enter the row
    if validity_enabled(spec.task.pick) and not row["valid"] and not row["invalid_reason"]:
        # ended before the execution's verdict
        merge_records(row, [ValidityColumns(invalid_reason="not_run")])
    if result.shared:
        result.trace = None  # pieces of it belong to other episodes
    merge_records(row, [WallTimeColumns(time.perf_counter() - wall_start)])
    return result


def _run(
    spec: EpisodeSpec,
    scene_cache: dict[Any, Any] | None,
    result: EpisodeResult,
    evaluation: SeedEvaluation,
    records: list[RowRecord],
) -> None:
    """Reset, candidates, feasibility, then the chosen candidate's execution: each stage takes
    what ``evaluation`` already knows, adds what it computes, and appends its row records."""
    if spec.task.not_runnable:
        raise EpisodeStopError("not_runnable", spec.task.not_runnable)
    if spec.task.handover is not None:  # a handover's second pick: its phases share no cache
        run_handover(spec, scene_cache, result, records)
        return
    setup = reset(spec, scene_cache, result, evaluation, records)
    try:
        planning = candidates(setup)
        choice = feasibility(planning)
        executed, shared = evaluation.executed(
            choice.chosen.pose_index, lambda: execute_chosen(planning, choice)
        )
        if shared:
            planning.record_plan_time()
    finally:
        result.shared = evaluation.used_shared
    records.extend(executed.records)
    if executed.stop is not None:
        raise EpisodeStopError(*executed.stop)  # type: ignore[arg-type]
