"""One pick episode: scene reset, candidate selection, feasibility, plan, execution, verdict.

``run_episode(spec, scene_cache)`` never raises for episode-level problems: every outcome is one
flat row (``EpisodeResult.row``, the columns of ``harness.runs.store``) with ``success`` and a
``failure_reason`` from the taxonomy (``harness.failures``):

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
(``harness.episode_streams``): the scene reset, the candidate draw, the lift offset, and per
annotated grasp its feasibility test and its executed plan -- same spec, same row. A candidate's
verdict and executed outcome therefore depend only on (task physics, seed, candidate), which lets
points that differ only in their selection keys share them (``harness.candidate_cache``; pass a
``CandidateCache`` to ``run_episode``). An episode that used any shared evaluation carries no
trace (``EpisodeResult.trace`` is None); run it without the cache to get one (same row).

The per-step record (``EpisodeResult.trace``) carries what a viewer needs: joint and object
trajectories, TCP poses, gripper width, finger forces, phases and events, every candidate with
its verdict, and the planned and executed TCP paths.

Scenes are cached per worker in ``scene_cache`` (any dict), keyed by (robot, objects, physics):
an episode on a cached scene only resets arrays.
"""

from __future__ import annotations

import json
import time
import traceback
from typing import Any

import mujoco

from harness.candidate_cache import CandidateCache, SeedEvaluation, evaluation_key
from harness.episode_spec import EpisodeResult, EpisodeSpec
from harness.episode_stages import (
    INIT_RECORD_TIME_S,
    SETTLE_TIME_S,
    WARMUP_TIME_S,
    EpisodeStopError,
    candidates,
    execute_chosen,
    feasibility,
    reset,
)
from harness.errors import EpisodeTimeoutError, HarnessError
from harness.pick.validity import validity_enabled
from harness.row import IDENTITY_COLUMNS, EpisodeRow, identity_columns
from harness.version import __version__

__all__ = [
    "INIT_RECORD_TIME_S",
    "SETTLE_TIME_S",
    "WARMUP_TIME_S",
    "EpisodeResult",
    "EpisodeSpec",
    "base_row",
    "run_episode",
]


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
        engine=spec.engine,
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
        key, evaluation = None, SeedEvaluation()
    else:
        key = evaluation_key(spec.task, spec.seed)
        if spec.engine != "mujoco":  # executed outcomes are the engine's own
            key = (f"{key[0]} engine={spec.engine}", key[1])
        evaluation = candidate_cache.evaluation(key)
    try:
        _run(spec, scene_cache, result, evaluation, key)
    except EpisodeStopError as stop:
        row["failure_reason"] = stop.reason
        row["error_message"] = stop.message
    except EpisodeTimeoutError as exc:  # harness.sim.budget: the run's limits, not an error
        row["failure_reason"] = "timeout"
        row["error_message"] = str(exc)
    except HarnessError as exc:
        row["failure_reason"] = "error"
        row["error_message"] = str(exc)
    except Exception as exc:  # any bug or library failure must not lose the episode
        row["failure_reason"] = "error"
        where = traceback.extract_tb(exc.__traceback__)[-1]
        row["error_message"] = (
            f"{type(exc).__name__}: {exc} (at {where.filename.rsplit('/', 1)[-1]}:{where.lineno})"
        )
    row["success"] = row["failure_reason"] == ""
    if validity_enabled(spec.task.pick) and not row["valid"] and not row["invalid_reason"]:
        row["invalid_reason"] = "not_run"  # ended before the execution's verdict
    if result.shared:
        result.trace = None  # pieces of it belong to other episodes
    row["wall_time_s"] = time.perf_counter() - wall_start
    return result


def _run(
    spec: EpisodeSpec,
    scene_cache: dict[Any, Any] | None,
    result: EpisodeResult,
    evaluation: SeedEvaluation,
    key: Any,
) -> None:
    """Reset, candidates, feasibility, then the chosen candidate's execution: each stage takes
    what ``evaluation`` already knows and adds what it computes."""
    setup = reset(spec, scene_cache, result, evaluation, key)
    try:
        planning = candidates(setup)
        choice = feasibility(planning)
        pose_index = choice.chosen.pose_index
        executed = evaluation.outcomes.get(pose_index)
        if executed is None:
            executed = execute_chosen(planning, choice)
            evaluation.outcomes[pose_index] = executed
            evaluation.stats.outcomes += 1
        else:
            setup.used_shared = True
            evaluation.stats.outcome_hits += 1
            planning.record_plan_time()
    finally:
        result.shared = setup.used_shared
    result.row.update(executed.columns)
    if executed.stop is not None:
        raise EpisodeStopError(*executed.stop)  # type: ignore[arg-type]
