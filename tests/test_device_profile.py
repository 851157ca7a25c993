"""The device profiler's kernel naming and stage grouping (its device runs need a GPU)."""

from __future__ import annotations

from harness.benchmarks.device_profile import Profile, kernel_name, stage


def test_kernel_names_lose_warps_hashes_and_closure_decorations() -> None:
    assert kernel_name("_solve_init_dof__locals__kernel_92449250") == "_solve_init_dof"
    assert kernel_name("track_use_3f2a9b1c") == "track_use"
    assert kernel_name("_linesearch_iterative_kernel__locals__kernel_3c7b697a") == (
        "_linesearch_iterative_kernel"
    )
    assert kernel_name("record") == "record"
    assert (
        kernel_name("forward kernel _update_gradient_JTCJ_dense") == "_update_gradient_JTCJ_dense"
    )


def test_stages_group_kernels_by_prefix_and_average_per_physics_step() -> None:
    assert stage("_linesearch_iterative_kernel") == "solver: linesearch"
    assert stage("track_use") == "harness"
    assert stage("_efc_contact_init") == "constraint rows"
    assert stage("kinematics_level") == "other"
    profile = Profile(physics_steps=4)
    profile.kernel_ms.update({"_update_gradient_grad": 2.0, "_linesearch_x": 6.0, "record": 1.0})
    profile.launches.update({"_update_gradient_grad": 8, "_linesearch_x": 8, "record": 1})
    assert profile.by_stage() == {
        "solver: linesearch": 1.5,
        "solver: gradient": 0.5,
        "harness": 0.25,
    }
    summary = profile.summary()
    assert summary["device_ms_per_step"] == 9.0 / 4
    assert summary["launches_per_step"] == 17 / 4
