"""The failure taxonomy of an episode (``FAILURE_REASONS`` below, in pipeline order; what each
means per semantics: docs/semantics.md): one definition for the executor and the row schema.

Kept in its own module, free of heavy imports, so that ``harness.pick.executor`` (MuJoCo) and
``harness.row`` (the row schema) can both name it without importing each other.
"""

from __future__ import annotations

from typing import Literal, get_args

# In pipeline order: the first cause wins. "" means success.
FailureReason = Literal[
    "",
    "filter_empty",
    "no_feasible_candidate",
    "plan_failed",
    "collision",
    "no_contact",
    "dropped",
    "lift_below_threshold",
    "velocity_invalid",
    "sim_unstable",
    "timeout",
    "not_runnable",
    "error",
]

# Rows that are no pick outcome and stay out of every rate: a pick that cannot run on its own
# (``TaskConfig.not_runnable``: it takes an object an earlier skill holds) and crashed or
# misconfigured episodes.
UNRATED_REASONS: tuple[str, ...] = ("not_runnable", "error")

# The failure causes alone (without the success value ""), in the same order.
FAILURE_REASONS: tuple[str, ...] = tuple(reason for reason in get_args(FailureReason) if reason)
