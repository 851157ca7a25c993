"""The first stage of an episode: the scene reset, and the ``Setup`` every later stage reads.

``harness.episode.pipeline.run_episode`` runs the stages in order: reset (here), candidates and
feasibility (``harness.episode.planning``), the chosen candidate's plan and execution
(``harness.episode.execution``). Each stage first asks the seed's evaluation
(``harness.episode.candidate_cache.SeedEvaluation``) what it already knows -- the reset's facts,
a candidate's verdict, a chosen candidate's executed outcome -- and computes only what is
missing. Without a shared cache the evaluation starts empty and every stage computes, as an
unshared episode always did.

The scene must hold the seed's untouched reset whenever something is computed (a feasibility
test reads the object poses; an execution steps from them). ``Setup.ensure_fresh`` re-runs the
reset (deterministic in the seed's scene stream) unless the scene's reset mark says it already
holds exactly that state.

Stages report their row columns as typed records (``harness.episode.records``) appended to
``Setup.records``; the pipeline merges them into the row in one place.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

from harness.config import PickConfig, TaskConfig
from harness.episode.candidate_cache import ResetFacts
from harness.episode.evaluation import SeedEvaluation
from harness.episode.records import RowRecord, SceneColumns
from harness.episode.result import EpisodeResult
from harness.episode.scene_cache import SceneBundle, get_scene
from harness.episode.spec import EpisodeSpec
from harness.episode.streams import EpisodeStreams
from harness.failures import FailureReason
from harness.pick.semantics import Semantics
from harness.planning.planner import PickPlanner
from harness.sim import Scene

# The reference's episode timeline (simbox_dual_workflow.py, PhysX at 1/30 s per step): place,
# step once, build the skill (it records obj_init_trans), settle 20 steps, generate the first
# skill's commands (grasp selection and feasibility, from the object pose at that moment), step
# 10 warm-up steps, then run the control loop. A shorter settle leaves objects placed tilted
# (orientation_mode random) still moving when the grasp is chosen.
INIT_RECORD_TIME_S = 1 / 30
SETTLE_TIME_S = 20 / 30
WARMUP_TIME_S = 10 / 30


class EpisodeStopError(Exception):
    """Ends an episode early with a failure reason (not an error)."""

    def __init__(self, reason: FailureReason, message: str) -> None:
        super().__init__(message)
        self.reason = reason
        self.message = message


@dataclass
class Setup:
    """The episode's scene, planner, random streams, the seed's evaluation and the row records
    the stages produced so far."""

    spec: EpisodeSpec
    result: EpisodeResult
    semantics: Semantics
    bundle: SceneBundle
    streams: EpisodeStreams
    evaluation: SeedEvaluation
    planner: PickPlanner
    records: list[RowRecord] = field(default_factory=list)
    synced: bool = False  # the planner holds this episode's planning world

    @property
    def scene(self) -> Scene:
        return self.bundle.scene

    @property
    def task(self) -> TaskConfig:
        return self.spec.task

    @property
    def pick(self) -> PickConfig:
        return self.spec.task.pick

    @property
    def arm(self) -> str:
        return self.spec.task.arm

    @property
    def facts(self) -> ResetFacts:
        facts = self.evaluation.known_reset
        assert facts is not None, "the reset runs before anything reads it"
        return facts

    def reset_scene(self) -> ResetFacts:
        """Run this seed's reset and read what it left (the scene now holds it)."""
        scene, task = self.scene, self.task
        self.evaluation.count_reset()
        reset = scene.reset(
            task, self.streams.scene(), settle_time=SETTLE_TIME_S,
            init_record_time=INIT_RECORD_TIME_S,
        )  # fmt: skip
        self.evaluation.mark_reset(self.bundle)
        self.synced = False
        return ResetFacts(
            T_world_base=scene.T_world_base(self.arm),
            T_world_object=scene.T_world_object(task.target_object.name),
            object_init_position=reset.object_init_position,
            q_now=scene.active_q(self.arm),
            settle_steps=reset.settle_steps,
            unstable=scene.unstable(),
        )

    def ensure_fresh(self) -> None:
        """Make the scene hold this seed's reset, running it unless it is already there."""
        if not self.evaluation.holds_reset(self.bundle):
            self.reset_scene()

    def ensure_synced(self) -> None:
        """A fresh scene and the planner synced to this episode's planning world."""
        self.ensure_fresh()
        if not self.synced:
            self.planner.sync(self.semantics.planning_world(self.task.target_object.name))
            self.synced = True

    def mark_stepped(self) -> None:
        """The scene is about to leave the reset state."""
        self.evaluation.mark_stepped(self.bundle)


def reset(
    spec: EpisodeSpec,
    scene_cache: dict[Any, Any] | None,
    result: EpisodeResult,
    evaluation: SeedEvaluation,
    records: list[RowRecord],
) -> Setup:
    """1. Reset: placement, home + noise, obj_init_trans after one reference step, settle.
    The reset's facts come from the seed's evaluation when an earlier episode ran it."""
    task = spec.task
    clock = time.perf_counter()
    bundle = get_scene(task, scene_cache)
    scene = bundle.scene
    result.scene = scene
    target = scene.objects[task.target_object.name].asset
    gripper = scene.robot.arm(task.arm).gripper  # a clear error for an unknown arm
    semantics = Semantics.from_pick(task.pick)
    columns = (target.friction, target.mass, gripper.force_limit, scene.robot.gripper_variant)
    records.append(SceneColumns(*columns, task.pick.speed_scale, semantics.name))
    planner = bundle.planner(task.arm)
    streams = EpisodeStreams(spec.seed)
    setup = Setup(spec, result, semantics, bundle, streams, evaluation, planner, records)
    facts = evaluation.facts(setup.reset_scene)
    result.timings["settle_steps"] = float(facts.settle_steps)
    result.timings["setup_s"] = time.perf_counter() - clock
    if facts.unstable is not None:
        raise EpisodeStopError("sim_unstable", f"while settling: {facts.unstable}")
    return setup
