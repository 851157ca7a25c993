"""The ``harness`` command line: argument parsing and dispatch.

Each command group's behaviour lives in ``harness/commands/<group>.py`` and is imported lazily,
so ``harness --help`` stays fast and a broken optional dependency only affects its own command.
Every handler returns an exit code. A ``ConfigError`` (or any ``HarnessError``) is printed as one
line on stderr with exit code 2 -- never a traceback.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import sys
from collections.abc import Callable, Sequence
from typing import TypeAlias

from harness.commands.flags import (
    EPISODES,
    GRASP_COUNT,
    RECORD_HELP,
    SEED,
    WORKERS,
    bounded_int,
    finite,
    positive,
    record_policy,
    seconds_at_least,
)
from harness.commands.objects_parser import add_objects
from harness.commands.tune_parser import add_tune
from harness.errors import HarnessError
from harness.version import __version__

# The object ``add_subparsers`` returns (argparse has no public name for its type).
Subparsers: TypeAlias = "argparse._SubParsersAction[argparse.ArgumentParser]"


def _handler(module: str, function: str):
    """Lazy reference to ``harness.commands.<module>.<function>``."""

    def call(args: argparse.Namespace) -> int:
        mod = importlib.import_module(f"harness.commands.{module}")
        return int(getattr(mod, function)(args) or 0)

    return call


def _add_progress_every(p: argparse.ArgumentParser) -> None:
    from harness.runs.progress import EVERY_S, MIN_EVERY_S

    p.add_argument(
        "--progress-every",
        type=seconds_at_least(MIN_EVERY_S),
        metavar="SECONDS",
        help=f"seconds between progress lines without a terminal (default {EVERY_S:g}, "
        f"at least {MIN_EVERY_S:g})",
    )


def _add_filter_args(parser: argparse.ArgumentParser) -> None:
    for axis in "xyz":
        parser.add_argument(
            f"--filter-{axis}",
            nargs="+",
            metavar=("DIR", "A"),
            help=f"filter_{axis}_dir: DIR ANGLE [ANGLE2] (DIR: forward|backward|upward|downward)",
        )


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="harness",
        description="pick-harness: sweep grasp-filter settings of the InternDataEngine Pick "
        "skill across robots on MuJoCo, and report which settings make picks succeed.",
    )
    parser.add_argument("--version", action="version", version=f"pick-harness {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for add_command in COMMANDS:
        add_command(sub)
    return parser


def _add_validate(sub: Subparsers) -> None:
    """``harness validate FILE...``"""
    p = sub.add_parser("validate", help="validate task and sweep YAML files")
    p.add_argument("files", nargs="+", metavar="FILE", help="task or sweep YAML files to check")
    p.set_defaults(func=_handler("validate", "main"))


def _add_run(sub: Subparsers) -> None:
    """``harness run [TASK.yaml] [--interndata TASK.yaml] ...``"""
    p = sub.add_parser("run", help="run episodes of one task and write a run directory")
    p.add_argument("task", nargs="?", metavar="TASK.yaml", help="a task YAML (tasks/pick/*.yaml)")
    p.add_argument("--interndata", metavar="TASK.yaml", help="an InternDataEngine task YAML")
    p.add_argument("--asset-root", metavar="DIR", help="root for InternDataEngine asset paths")
    p.add_argument("--object", action="append", default=[], metavar="NAME=PATH", help="an asset")
    p.add_argument("--episodes", type=EPISODES, default=10, help="episodes to run (seeds)")
    p.add_argument("--seed", type=SEED, default=0, help="seed of the first episode's stream")
    p.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        dest="overrides",
        help="override a task key, e.g. pick.filter_z_dir='[downward,150]' (repeatable)",
    )
    p.add_argument("--out", metavar="DIR", help="run directory (default reports/<name>-<time>)")
    p.add_argument("--record", type=record_policy, default="failures", help=RECORD_HELP)
    p.add_argument("--workers", type=WORKERS, default=1, help="worker processes (default 1)")
    _add_progress_every(p)
    p.set_defaults(func=_handler("run", "main"))


def _add_sweep(sub: Subparsers) -> None:
    """``harness sweep [SWEEP.yaml] [--resume RUN_DIR] ...``"""
    from harness.runs.limits import MAX_EPISODES, MAX_POINTS  # the help says the numbers

    p = sub.add_parser("sweep", help="run a sweep YAML: tasks x points x seeds")
    p.add_argument(
        "sweep", metavar="SWEEP.yaml", nargs="?", help="a sweep YAML (omit with --resume)"
    )
    p.add_argument("--out", metavar="DIR", help="run directory (default reports/<name>-<time>)")
    p.add_argument("--resume", metavar="RUN_DIR", help="run only the episodes missing in RUN_DIR")
    p.add_argument(
        "--force",
        action="store_true",
        help="with --resume: continue even if RUN_DIR/sweep.yaml changed since the run began",
    )
    p.add_argument(
        "--retry-errors",
        action="store_true",
        help="with --resume: run episodes whose row is an error (crash, input problem) again",
    )
    p.add_argument("--workers", type=WORKERS, help="worker processes (default: one per core)")
    p.add_argument(
        "--backend",
        choices=["serial", "process", "ray"],
        default="process",
        help="where episodes run: this process, a process pool (default) or Ray",
    )
    p.add_argument("--address", help="Ray cluster address (with --backend ray)")
    p.add_argument("--record", type=record_policy, help=f"{RECORD_HELP} (overrides the sweep)")
    p.add_argument("--episodes-per-point", type=EPISODES, help="override episodes_per_point")
    p.add_argument(
        "--no-share",
        action="store_true",
        help="evaluate every point on its own instead of sharing each seed's candidate "
        "evaluations between points that differ only in filters (same rows, slower)",
    )
    p.add_argument(
        "--max-episodes",
        type=bounded_int(1, 10**9),
        metavar="N",
        help=f"refuse sweeps larger than this many episodes (default: {MAX_EPISODES:,})",
    )
    p.add_argument(
        "--max-points",
        type=bounded_int(1, 10**7),
        help=f"refuse sweeps with more (task, point) pairs (default: {MAX_POINTS:,})",
    )
    p.add_argument("--no-progress", action="store_true", help="no progress bar (logs, CI)")
    _add_progress_every(p)
    _add_objective(p, recorded=True)
    _add_videos(p, default=False)
    p.set_defaults(func=_handler("sweep", "main"))


def _add_report(sub: Subparsers) -> None:
    """``harness report RUN_DIR``"""
    p = sub.add_parser("report", help="rebuild summary, plots and report of a run directory")
    p.add_argument("run_dir", metavar="RUN_DIR", help="a run directory (harness sweep or run)")
    _add_objective(p, recorded=True)
    _add_videos(p, default=True)
    _add_progress_every(p)
    p.set_defaults(func=_handler("report", "main"))


def _add_sensitivity(sub: Subparsers) -> None:
    """``harness sensitivity [--out DIR] [--episodes N] ...``"""
    p = sub.add_parser(
        "sensitivity",
        help="move every chosen value to 0.5x and 2x on its robot's canonical tasks",
        description="One sweep per value robot.yaml or a task default marks chosen (no public "
        "source): the value at 0.5x and 2x (or its plausible range) x two approach cones on its "
        "robot's canonical tasks, plus a baseline at every default; then one table of how each "
        "arm's valid rate and best setting move (docs/results.md). Rerunning resumes.",
    )
    p.add_argument("--out", metavar="DIR", default="reports/sensitivity", help="run folder")
    p.add_argument("--episodes", type=WORKERS, default=20, help="seeds per point (default 20)")
    p.add_argument("--seed", type=SEED, default=5500, help="sweep seed of every sweep")
    p.add_argument("--workers", type=WORKERS, default=2, help="worker processes (default 2)")
    p.add_argument("--robots", nargs="+", metavar="ROBOT", help="only these robots")
    p.add_argument("--only", nargs="+", metavar="KEY", help="only values swept by these keys")
    p.add_argument(
        "--examples", metavar="DIR",
        help="InternData example folder (default ../shared/datasets/interndata-examples): the "
        "Split ALOHA grip values also run on its bottle_1",
    )  # fmt: skip
    p.add_argument(
        "--handover", metavar="FILE",
        help="a handover InternData file: runs the release rule pick.max_first_gripper_force",
    )  # fmt: skip
    p.add_argument(
        "--handover-object", action="append", metavar="NAME=PATH",
        help="substitute an object of the handover file (as harness run --object)",
    )  # fmt: skip
    p.add_argument("--plan", action="store_true", help="list the sweeps and sizes; run nothing")
    p.set_defaults(func=_handler("sensitivity", "main"))


def _add_videos(p: argparse.ArgumentParser, default: bool) -> None:
    p.add_argument(
        "--videos",
        action=argparse.BooleanOptionalAction,
        default=default,
        help="replay one success and one failure per robot arm and embed their MP4s in "
        "report.html (a few seconds each)",
    )


def _add_objective(p: argparse.ArgumentParser, recorded: bool = False) -> None:
    default = "the run's recorded one, else valid" if recorded else "valid"
    p.add_argument(
        "--objective", choices=["valid", "reference"], default=None if recorded else "valid",
        help="the verdict that ranks settings, colours the heatmaps and answers the first screen "
        f"(the other beside it): valid (the grasp holds) or reference (default: {default})",
    )  # fmt: skip


def _add_compare(sub: Subparsers) -> None:
    """``harness compare RUN_A RUN_B [--csv FILE]``"""
    p = sub.add_parser(
        "compare", help="per-setting rate differences of two runs (McNemar / two-proportion)"
    )
    p.add_argument("run_a", metavar="RUN_A", help="the baseline run directory (A)")
    p.add_argument("run_b", metavar="RUN_B", help="the run directory compared with it (B)")
    p.add_argument("--csv", metavar="FILE", help="also write the comparison table as CSV")
    p.add_argument("--match", choices=["auto", "settings", "arm"], default="auto",
                   help="pair by identical settings, or by robot, arm and object whatever "
                   "filters ran (a tuned task file vs the current one); auto: by arm when "
                   "each run holds one setting per robot, arm and object")  # fmt: skip
    _add_objective(p)
    p.set_defaults(func=_handler("report", "compare"))


def _add_view(sub: Subparsers) -> None:
    """``harness view FILE.rrd``"""
    p = sub.add_parser("view", help="open a Rerun recording (or say how to)")
    p.add_argument("file", metavar="FILE.rrd|RUN_DIR", help="a recording, or a run directory")
    p.set_defaults(func=_handler("view", "main"))


def _add_replay(sub: Subparsers) -> None:
    """``harness replay RUN_DIR EPISODE_ID [--record FILE.rrd] [--video FILE.mp4]``"""
    p = sub.add_parser(
        "replay", help="run one stored episode again; check its row, record it, film it"
    )
    p.add_argument("run_dir", metavar="RUN_DIR", help="a run directory (sweep or run)")
    p.add_argument("episode_id", metavar="EPISODE_ID", help="the episode_id column of its row")
    p.add_argument("--record", metavar="FILE.rrd", help="write the episode's Rerun recording")
    p.add_argument("--video", metavar="FILE.mp4", help="write an offscreen MP4 of the episode")
    p.set_defaults(func=_handler("replay", "main"))


def _add_grasps(sub: Subparsers) -> None:
    """``harness grasps inspect | generate | audit``"""
    grasps = sub.add_parser("grasps", help="inspect or generate grasp annotation files")
    gsub = grasps.add_subparsers(dest="grasps_command", metavar="SUBCOMMAND", required=True)
    p = gsub.add_parser("inspect", help="filter and order the grasps of a file for a robot")
    p.add_argument("file", metavar="FILE", help="an N x 17 grasp file (.npy)")
    p.add_argument("--robot", required=True, help="robot whose convention and base frame apply")
    p.add_argument("--arm", choices=["left", "right"], default="left", help="arm of the robot")
    p.add_argument(
        "--object-pose",
        nargs=7,
        type=float,
        metavar=("X", "Y", "Z", "QW", "QX", "QY", "QZ"),
        help="object pose in the arm base frame, quaternion wxyz (default: identity)",
    )
    _add_filter_args(p)
    p.add_argument("--approach", nargs="+", metavar=("DIR", "A"), help="approach_filter")
    p.add_argument("--facing", nargs="+", metavar=("DIR", "A"), help="facing_filter")
    p.add_argument(
        "--direction-to-obj",
        choices=["left", "right"],
        help="pick.direction_to_obj: keep grasps on the base's +y (left) or -y (right) side",
    )
    p.add_argument(
        "--constraints",
        nargs=3,
        metavar=("AXIS", "MIN", "MAX"),
        help="pick.constraints: keep grasps whose TCP lies in [MIN, MAX] of the object's range",
    )
    p.add_argument("--grasp-scale", type=float, default=1.0, help="pick.grasp_scale (translations)")
    p.add_argument(
        "--semantics",
        choices=["reference", "strict"],
        default="reference",
        help="pick.semantics: reference (InternDataEngine, quirks included) or strict",
    )
    p.add_argument("--seed", type=SEED, default=0, help="seed of the candidate draw")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.add_argument("--plot", metavar="FILE.png", help="plot the EE axis directions to a PNG")
    p.set_defaults(func=_handler("grasps", "inspect"))
    p = gsub.add_parser("generate", help="antipodal grasp annotations for a mesh (N x 17)")
    p.add_argument("mesh", metavar="MESH", help="a mesh file (.obj, .stl, .ply, .glb, .usd)")
    p.add_argument("--out", required=True, metavar="FILE.npy", help="the grasp file to write")
    p.add_argument("-n", "--num", type=GRASP_COUNT, default=3000, help="grasps to generate")
    p.add_argument(
        "--seed", type=SEED, default=0, help="seed of the sampler (same seed, same file)"
    )
    p.add_argument("--scale", type=float, default=1.0, help="scale applied to the mesh")
    p.add_argument(
        "--max-width", type=float, default=0.1, help="largest gripper opening in m (0, 1]"
    )
    p.set_defaults(func=_handler("graspgen", "generate"))
    p = gsub.add_parser("audit", help="executed grasps of a run: which never succeed and why")
    p.add_argument("run_dir", metavar="RUN_DIR", help="a run directory (sweep, run or tune)")
    p.add_argument(
        "--min-trials",
        type=bounded_int(1, 1_000_000),
        default=3,
        help="trials a grasp needs before it can be flagged as never succeeding (default 3)",
    )
    p.set_defaults(func=_handler("grasps", "audit"))


def _add_robots(sub: Subparsers) -> None:
    """``harness robots list | show``"""
    robots = sub.add_parser("robots", help="list and show robots")
    rsub = robots.add_subparsers(dest="robots_command", metavar="SUBCOMMAND", required=True)
    p = rsub.add_parser("list", help="list the robots")
    p.set_defaults(func=_handler("robots", "list_robots"))
    p = rsub.add_parser("show", help="describe a robot; optionally render it at home")
    p.add_argument("name", metavar="NAME", help="a robot under robots/ (harness robots list)")
    p.add_argument("--render", metavar="FILE.png", help="render the robot at home to a PNG")
    p.add_argument(
        "--distance", type=positive, metavar="M",
        help="with --render: camera distance from the look-at point (default 1.9, 2.1 for a "
        "robot standing on the floor)",
    )  # fmt: skip
    p.add_argument(
        "--azimuth", type=finite, default=-150.0, metavar="DEG",
        help="with --render: camera azimuth (default -150: front right of the robot)",
    )  # fmt: skip
    p.add_argument(
        "--elevation", type=finite, default=-20.0, metavar="DEG",
        help="with --render: camera elevation (default -20)",
    )  # fmt: skip
    p.set_defaults(func=_handler("robots", "show"))


def _add_bench(sub: Subparsers) -> None:
    """``harness bench [--quick] [--json FILE] [--only SECTION...]``"""
    from harness.benchmarks.framework import SECTIONS

    p = sub.add_parser("bench", help="measure speed on this machine")
    p.add_argument("--quick", action="store_true", help="fewer repetitions (prints an estimate)")
    p.add_argument("--json", metavar="FILE", help="also write every figure as JSON")
    p.add_argument(
        "--only",
        nargs="+",
        metavar="SECTION",
        help=f"run only these sections: {' '.join(SECTIONS)}",
    )
    p.set_defaults(func=_handler("bench", "main"))


# Every command's parser builder, in the order of ``harness --help``.
COMMANDS: tuple[Callable[[Subparsers], None], ...] = (
    _add_validate,
    _add_run,
    _add_sweep,
    _add_report,
    _add_compare,
    lambda sub: add_tune(sub, _handler, _add_progress_every),
    _add_sensitivity,
    _add_view,
    _add_replay,
    _add_grasps,
    _add_robots,
    lambda sub: add_objects(sub, _handler),
    _add_bench,
)


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 0
    _terminate_like_ctrl_c()
    if getattr(args, "progress_every", None) is not None:
        from harness.runs.progress import set_progress_interval

        set_progress_interval(args.progress_every)
    try:
        code = args.func(args)
        sys.stdout.flush()  # a full disk under stdout fails here, not at interpreter exit
        return code
    except HarnessError as exc:
        return _fail(str(exc))
    except KeyboardInterrupt:  # a second Ctrl-C / SIGTERM: say what was kept, how to go on
        rundir = sys.modules.get("harness.runs.rundir")
        _stderr(rundir.interrupted_line() if rundir is not None else "interrupted")
        return 130
    except BrokenPipeError:  # e.g. `harness grasps inspect ... | head`
        _silence_stdout()
        return 0
    except OSError as exc:  # the environment said no: read-only dir, full disk, missing folder
        return _fail(_os_error_line(exc))


def _terminate_like_ctrl_c() -> None:
    """SIGTERM (``kill``, a scheduler's stop) ends a command as Ctrl-C does: the run stops its
    workers, keeps what finished and exits 130 (it used to die at once and leave orphaned
    workers writing BrokenPipe tracebacks)."""
    import signal
    import threading

    def on_term(signum: int, frame: object) -> None:
        raise KeyboardInterrupt

    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, on_term)


def _os_error_line(exc: OSError) -> str:
    """``[Errno 30] Read-only file system: 'x'`` -> ``x: read-only file system``."""
    reason = (exc.strerror or str(exc)).lower()
    where = exc.filename if exc.filename is not None else "stdout/stderr"
    return f"{where}: {reason}"


def _fail(line: str) -> int:
    _stderr(f"error: {line}")
    return 2


def _stderr(line: str) -> None:
    """One line on stderr; a stdout that cannot be written (a full disk) is silenced so the
    interpreter's exit flush does not print a second, traceback-like message."""
    from harness.commands.console import visible  # names in the line: controls shown

    _silence_stdout()
    with contextlib.suppress(OSError):
        print(visible(line), file=sys.stderr, flush=True)


def _silence_stdout() -> None:
    import os

    try:
        sys.stdout.flush()
    except (OSError, ValueError):
        with contextlib.suppress(OSError):
            sys.stdout = open(os.devnull, "w", encoding="utf-8")  # noqa: SIM115 (until exit)


if __name__ == "__main__":
    sys.exit(main())
