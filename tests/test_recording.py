"""Episode recordings explain their outcome (issue 14), read back with Rerun's own reader: the
scene posed whatever the outcome, candidates labelled with their reasons, targets, contacts, the
verdict document and the blueprint view that shows it; and the ``candidate_failures`` column."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from helpers import make_task, write_box

from harness.episode import EpisodeSpec, run_episode
from harness.viz.recording import record_episode

FAR = {"placement": {"pos_range": [[0.75, 0.3, 0.0], [0.75, 0.3, 0.0]]}}  # 1.07 m from the FR3


@pytest.fixture(scope="module")
def cube(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_box(tmp_path_factory.mktemp("recording_cube"), (0.04, 0.04, 0.04), "cube")


@pytest.fixture(scope="module")
def cache() -> dict:
    return {}


def read_back(path: Path) -> tuple[dict[str, dict[str, int]], dict[str, list]]:
    """Per entity, the rows of each component; and the values of the text-like components."""
    from rerun.chunk import RrdReader

    rows: dict[str, dict[str, int]] = {}
    values: dict[str, list] = {}
    for chunk in RrdReader(str(path)).stream().to_chunks():
        batch = chunk.to_record_batch()
        counts = rows.setdefault(chunk.entity_path, {})
        for name in batch.schema.names:
            if ":" not in name:
                continue  # an index or row id column
            counts[name] = counts.get(name, 0) + chunk.num_rows
            if name.endswith((":text", ":labels")):
                values.setdefault(f"{chunk.entity_path}#{name}", []).extend(
                    batch.column(name).to_pylist()
                )
    return rows, values


def blueprint_views(path: Path) -> dict[str, str]:
    """The recording's blueprint: view origin -> view class."""
    from rerun.chunk import RrdReader

    reader = RrdReader(str(path))
    views: dict[str, str] = {}
    for chunk in reader.stream(store=reader.blueprints()[0]).to_chunks():
        batch = chunk.to_record_batch()
        if "ViewBlueprint:space_origin" in batch.schema.names:
            origin = batch.column("ViewBlueprint:space_origin").to_pylist()[0][0]
            kind = batch.column("ViewBlueprint:class_identifier").to_pylist()[0][0]
            views[origin] = kind
    return views


def body_entities(rows: dict[str, dict[str, int]]) -> set[str]:
    """The ``/world/bodies/<body>`` entities that carry geometry."""
    return {
        path.rsplit("/", 1)[0]
        for path in rows
        if path.startswith("/world/bodies/") and path.rsplit("/", 1)[1].startswith("geom")
    }


def flatten(values: list) -> list[str]:
    out: list[str] = []
    for value in values:
        out.extend(flatten(value) if isinstance(value, list) else [str(value)])
    return out


STOPPED_CASES = {
    # An object 1.07 m away: reference proceeds with the last candidate, whose plan fails.
    "plan_failed": ({}, FAR),
    "no_feasible_candidate": ({"semantics": "strict"}, FAR),
    "filter_empty": ({"semantics": "strict", "filter_z_dir": ["upward", 30]}, {}),
}


@pytest.mark.parametrize("reason", list(STOPPED_CASES))
def test_recording_of_a_stopped_episode_is_posed_and_says_why(
    reason: str, cube: Path, cache: dict, tmp_path: Path
) -> None:
    """Issue 14: an episode that never moved still shows its scene at reset (transform rows for
    every body), its candidates with reasons, and the failure message in a text view."""
    pick, obj = STOPPED_CASES[reason]
    task = make_task("fr3", "left", cube, pick=pick, object=obj)
    result = run_episode(EpisodeSpec(task=task, seed=0), cache)
    assert result.failure_reason == reason, result.row["error_message"]
    assert result.trace is not None and len(result.trace.time) == 0  # nothing was executed
    path = record_episode(result, tmp_path / f"{reason}.rrd", task)
    rows, values = read_back(path)

    bodies = body_entities(rows)
    assert len(bodies) > 10 and "/world/bodies/target" in bodies
    for body in bodies:
        assert rows[body].get("Transform3D:translation", 0) > 0, body
    document = "".join(flatten(values["/verdict#TextDocument:text"]))
    assert result.row["error_message"] and result.row["error_message"] in document
    assert f"FAILURE: {reason}" in document
    assert blueprint_views(path).get("/verdict") == "TextDocument"
    assert "/world/candidates/chosen" not in rows  # nothing feasible was chosen
    if reason == "filter_empty":
        assert "/world/candidates/rejected" in rows
        return
    failures = json.loads(result.row["candidate_failures"])
    assert failures and sum(failures.values()) == len(result.trace.tested_index)
    labels = flatten(values["/world/candidates/infeasible#Arrows3D:labels"])
    assert labels and all(any(stage in label for stage in failures) for label in labels)
    for stage, count in failures.items():
        assert f"| {stage} | {count} |" in document
    assert "/world/targets/tested/infeasible/pregrasp" in rows
    if reason == "plan_failed":  # the reference went on with the last tested candidate
        fallback = flatten(values["/world/candidates/fallback#Arrows3D:labels"])
        assert len(fallback) == 1 and "none feasible" in fallback[0]
        assert {"/world/targets/chosen/pre-grasp", "/world/targets/chosen/grasp"} <= set(rows)
    else:
        assert "/world/candidates/fallback" not in rows
        for stage, count in failures.items():
            assert f"{stage} {count}" in result.row["error_message"]


def test_candidate_failures_count_the_distinct_failed_candidates(cube: Path, cache: dict) -> None:
    """Over real episodes (a success, a plan failure): the per-stage counts plus the feasible
    candidates make the distinct candidates tested, which never exceed the draws."""
    far = make_task("fr3", "left", cube, object=FAR)
    near = make_task("fr3", "left", cube)
    checked = 0
    for task in (near, far):
        for seed in (0, 1):
            result = run_episode(EpisodeSpec(task=task, seed=seed), cache)
            row, trace = result.row, result.trace
            failures = json.loads(row["candidate_failures"])
            distinct = len(set(trace.tested_index.tolist()))
            assert sum(failures.values()) + row["n_feasible"] == distinct
            assert distinct <= row["n_tested"]
            assert all(count > 0 for count in failures.values())
            checked += 1
            if task is far:
                assert row["n_feasible"] == 0 and row["n_tested"] == 20 and failures
    assert checked == 4


def test_success_recording_has_contacts_and_chosen_targets(
    cube: Path, cache: dict, tmp_path: Path
) -> None:
    """A real pick: finger-object contact forces push into the object, their normal parts
    sum to the finger forces, and the recording animates bodies and contacts."""
    task = make_task("fr3", "left", cube)
    result = next(
        r
        for r in (run_episode(EpisodeSpec(task=task, seed=s), cache) for s in range(5))
        if r.success
    )
    trace = result.trace
    contacts = trace.contacts
    assert contacts is not None and len(contacts.row) > 50
    centre = trace.object_pose[contacts.row, :3]
    inward = np.einsum("ij,ij->i", contacts.force, centre - contacts.position)
    assert np.mean(inward > 0) > 0.95
    touching = contacts.sampled[np.isin(contacts.sampled, contacts.row)]
    assert len(touching) < 0.6 * len(trace.time)  # sampled at ~30 Hz of the ~100 Hz rows
    row = int(touching[np.argmax(trace.finger_forces[touching].sum(axis=1))])
    here = contacts.row == row
    total = np.linalg.norm(contacts.force[here].sum(axis=0))
    assert total <= trace.finger_forces[row].sum() * 1.5  # friction adds, opposite fingers cancel
    for finger in (0, 1):
        mine = here & (contacts.finger == finger)
        normal_part = np.linalg.norm(contacts.force[mine].sum(axis=0))
        assert normal_part == pytest.approx(trace.finger_forces[row, finger], rel=0.3)

    path = record_episode(result, tmp_path / "success.rrd", task)
    rows, values = read_back(path)
    assert all(rows[b]["Transform3D:translation"] > 10 for b in body_entities(rows))
    assert rows["/world/contacts/points"]["Points3D:positions"] > 10
    assert rows["/world/contacts/forces"]["Arrows3D:vectors"] > 10
    chosen = flatten(values["/world/candidates/chosen#Arrows3D:labels"])
    assert chosen == [f"chosen #{result.row['chosen_index']}"]
    targets = {"/world/targets/chosen/pre-grasp", "/world/targets/chosen/grasp"}
    assert targets <= set(rows) and "/world/plan/tcp" in rows
    assert "SUCCESS" in "".join(flatten(values["/verdict#TextDocument:text"]))
    views = blueprint_views(path)
    assert views["/verdict"] == "TextDocument" and views["/plots/object_z"] == "TimeSeries"
