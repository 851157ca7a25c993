"""Timed trajectories: profiles (timed pieces) and the ``Trajectory`` made of their segments.

A ``Trajectory`` is a sequence of timed segments (transport, approach, lift, gripper moves, holds)
that the executor samples by time; ``Trajectory.concatenate`` plays several plans as one.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from harness.planning.timing.inputs import as_vector, resolve_joint_names

# Concatenated segments must meet within this distance (max-norm).
CONTINUITY_TOLERANCE = 1e-6


Samples = tuple[np.ndarray, np.ndarray, np.ndarray]


class Profile(Protocol):
    """One timed piece: positions, velocities and accelerations at times in [0, duration]."""

    @property
    def duration(self) -> float:
        """Length of the piece (s); read-only here, so frozen profiles satisfy the protocol."""
        ...

    def evaluate(self, ts: np.ndarray) -> Samples:
        """``(q, qd, qdd)``, each ``(len(ts), dof)``, for times already clipped to the piece."""
        ...


# --------------------------------------------------------------------------------------------
# Profiles


@dataclass(frozen=True)
class HoldProfile:
    """Stand still at ``q`` for ``duration`` seconds."""

    q: np.ndarray
    duration: float

    def evaluate(self, ts: np.ndarray) -> Samples:
        n = len(ts)
        zeros = np.zeros((n, len(self.q)))
        return np.broadcast_to(self.q, (n, len(self.q))).copy(), zeros, zeros.copy()


@dataclass(frozen=True)
class Segment:
    """One timed piece of a trajectory, starting at ``start_time`` within it."""

    label: str
    method: str
    start_time: float
    profile: Profile

    @property
    def duration(self) -> float:
        return self.profile.duration

    @property
    def end_time(self) -> float:
        return self.start_time + self.profile.duration


@dataclass(frozen=True)
class Trajectory:
    """A timed joint trajectory made of consecutive segments; sample it with ``sample(t)``.

    Times outside ``[0, duration]`` are clipped, so sampling past the end holds the final
    position at rest. ``phases()`` names the segments (``transport``, ``approach``, ...), which
    the executor uses to know when the approach ends.
    """

    joint_names: tuple[str, ...]
    segments: tuple[Segment, ...]
    _starts: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if not self.segments:
            raise ValueError("a Trajectory needs at least one segment")
        object.__setattr__(
            self, "_starts", np.array([segment.start_time for segment in self.segments])
        )

    # -- construction -------------------------------------------------------------------------

    @classmethod
    def from_profile(
        cls, profile: Profile, method: str, joint_names: Sequence[str] | None, label: str = ""
    ) -> Trajectory:
        q0, _, _ = profile.evaluate(np.zeros(1))
        names = resolve_joint_names(joint_names, q0.shape[1])
        return cls(names, (Segment(label or method, method, 0.0, profile),))

    @classmethod
    def hold(
        cls,
        q: Sequence[float] | np.ndarray,
        duration: float,
        joint_names: Sequence[str] | None = None,
        label: str = "hold",
    ) -> Trajectory:
        """Stand still at ``q`` for ``duration`` seconds (>= 0)."""
        if not duration >= 0.0:
            raise ValueError(f"hold duration must be >= 0, got {duration}")
        q = as_vector(q, "q")
        return cls.from_profile(HoldProfile(q, float(duration)), "hold", joint_names, label)

    @classmethod
    def concatenate(
        cls, parts: Sequence[Trajectory], tolerance: float = CONTINUITY_TOLERANCE
    ) -> Trajectory:
        """Play ``parts`` one after the other; each must start where the previous one ended."""
        if not parts:
            raise ValueError("concatenate needs at least one trajectory")
        names = parts[0].joint_names
        segments: list[Segment] = []
        offset = 0.0
        previous: Trajectory | None = None
        for index, part in enumerate(parts):
            if part.joint_names != names:
                raise ValueError(
                    f"trajectory {index} has joints {part.joint_names}, expected {names}"
                )
            if previous is not None:
                gap = float(np.max(np.abs(part.start_position - previous.end_position)))
                if gap > tolerance:
                    raise ValueError(
                        f"trajectory {index} starts {gap:.3g} away from where trajectory "
                        f"{index - 1} ends (tolerance {tolerance:g})"
                    )
            for segment in part.segments:
                segments.append(
                    Segment(
                        segment.label, segment.method, offset + segment.start_time, segment.profile
                    )
                )
            offset += part.duration
            previous = part
        return cls(names, tuple(segments))

    def with_label(self, label: str) -> Trajectory:
        """The same trajectory with every segment renamed ``label`` (e.g. ``"approach"``)."""
        segments = tuple(Segment(label, s.method, s.start_time, s.profile) for s in self.segments)
        return Trajectory(self.joint_names, segments)

    # -- properties ---------------------------------------------------------------------------

    @property
    def dof(self) -> int:
        return len(self.joint_names)

    @property
    def duration(self) -> float:
        return self.segments[-1].end_time

    @property
    def method(self) -> str:
        """``toppra`` / ``ruckig`` / ``hold`` for one method, ``concat`` for a mixture."""
        methods = {segment.method for segment in self.segments}
        return methods.pop() if len(methods) == 1 else "concat"

    @property
    def start_position(self) -> np.ndarray:
        return self.sample(0.0)[0]

    @property
    def end_position(self) -> np.ndarray:
        return self.sample(self.duration)[0]

    def phases(self) -> list[tuple[str, float, float]]:
        """``(label, start, end)`` per run of equally labelled segments, in time order."""
        out: list[tuple[str, float, float]] = []
        for segment in self.segments:
            if out and out[-1][0] == segment.label:
                out[-1] = (segment.label, out[-1][1], segment.end_time)
            else:
                out.append((segment.label, segment.start_time, segment.end_time))
        return out

    # -- sampling -----------------------------------------------------------------------------

    def sample(self, t: float) -> Samples:
        """``(q, qd, qdd)`` at time ``t`` (clipped to ``[0, duration]``), each ``(dof,)``."""
        q, qd, qdd = self.sample_many(np.array([t], dtype=float))
        return q[0], qd[0], qdd[0]

    def sample_many(self, ts: Sequence[float] | np.ndarray) -> Samples:
        """Vectorised ``sample``: each output is ``(len(ts), dof)``."""
        ts = np.clip(np.asarray(ts, dtype=float).reshape(-1), 0.0, self.duration)
        q = np.empty((len(ts), self.dof))
        qd = np.empty_like(q)
        qdd = np.empty_like(q)
        # A time on a boundary belongs to the later segment; zero-length segments never win
        # except at the very end, where the last segment is used.
        index = np.searchsorted(self._starts, ts, side="right") - 1
        index = np.clip(index, 0, len(self.segments) - 1)
        for seg_index in np.unique(index):
            rows = index == seg_index
            segment = self.segments[seg_index]
            local = np.clip(ts[rows] - segment.start_time, 0.0, segment.duration)
            q[rows], qd[rows], qdd[rows] = segment.profile.evaluate(local)
        return q, qd, qdd

    def time_grid(self, dt: float) -> np.ndarray:
        """Times ``0, dt, 2 dt, ...`` up to and including ``duration``."""
        count = int(np.floor(self.duration / dt + 1e-9)) + 1
        ts = np.arange(count) * dt
        return ts if np.isclose(ts[-1], self.duration) else np.append(ts, self.duration)
