"""``harness tune``'s parser (kept out of cli.py, whose size the structure test bounds)."""

from __future__ import annotations

from typing import Any

from harness.commands.flags import EPISODES, SEED, WORKERS, bounded_int

Subparsers = Any


def add_tune(sub: Subparsers, _handler_of: Any, _progress_every: Any = None) -> None:
    """``_handler_of(module, function)`` and ``_progress_every(parser)``: cli.py's."""
    """``harness tune TASK_OR_SWEEP... [--episodes N] [--budget B] [--write DIR] ...``"""
    p = sub.add_parser(
        "tune", help="screen an approach x facing grid, race the best on fresh seeds, decide"
    )
    p.add_argument(
        "files",
        nargs="*",
        metavar="TASK_OR_SWEEP",
        help="task, sweep or InternDataEngine task files, folders or globs of them (a folder of "
        "per-object files is tuned as one template)",
    )
    p.add_argument("--asset-root", metavar="DIR", help="root for InternDataEngine asset paths")
    p.add_argument(
        "--object", action="append", default=[], metavar="NAME=PATH", help="an asset substitute"
    )
    p.add_argument(
        "--template",
        action="store_true",
        default=None,
        help="one setting per task over its objects (its sweep's object.mesh values), as a "
        "folder of per-object files is tuned: the objects' mean rate, exceptions tested",
    )
    p.add_argument(
        "--exception-seeds",
        type=bounded_int(1, 100_000),
        help="fresh paired seeds per object on which an object's own best setting is tested "
        "against its template (60)",
    )
    p.add_argument("--analyse", metavar="DIR", help="decide again from a tune's stored episodes")
    p.add_argument("--check", metavar="DIR", help="test a tune's decisions on fresh seeds")
    p.add_argument("--unit", action="append", help="--check: only this unit ('fr3 left cube')")
    p.add_argument("--episodes", type=EPISODES, help="seeds per setting (10; --check: 100)")
    p.add_argument("--step", type=bounded_int(1, 90), default=5, help="approach step (deg)")
    p.add_argument("--bands", type=bounded_int(0, 18), default=3, help="bands per cone")
    p.add_argument(
        "--directions",
        choices=["all", "canonical"],
        help="all (default): a coarse pass over every Pick direction on both axes, then the "
        "fine grid about the best; canonical: only the fine grid about downward / forward",
    )
    p.add_argument("--top", type=bounded_int(1, 20), help="settings raced against the current (3)")
    p.add_argument("--block", type=bounded_int(1, 1000), help="fresh seeds per race look (20)")
    p.add_argument(
        "--max-seeds",
        type=bounded_int(1, 100_000),
        help="fresh seeds per robot, arm and object at most (default: sized for 80%% power "
        "at a 5-point gain)",
    )
    p.add_argument(
        "--budget",
        metavar="N|Ns",
        help="race episodes (N) or episode-seconds (Ns, e.g. 300s) the race may use at most",
    )
    p.add_argument("--seed", type=SEED, help="sweep seed (the sweep's, else 0; --check: +200000)")
    p.add_argument("--out", metavar="DIR", help="the tune's directory (default: reports/)")
    p.add_argument("--workers", type=WORKERS, help="worker processes (default: one per core)")
    p.add_argument("--write", metavar="DIR", help="write tuned task files (keys merged) and diffs")
    p.add_argument(
        "--objective",
        choices=["valid", "reference"],
        help="decide by the validity verdict (default) or the reference success",
    )
    _progress_every(p)
    p.set_defaults(func=_handler_of("tune", "main"))
