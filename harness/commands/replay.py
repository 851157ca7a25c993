"""``harness replay RUN_DIR EPISODE_ID [--record FILE.rrd] [--video FILE.mp4]``: run one stored
episode again from its row (task, point, full seed), check the new row equals the stored one,
and write its Rerun recording and/or an offscreen MP4."""

from __future__ import annotations

import argparse
from pathlib import Path

from harness.commands.console import make_console, styled
from harness.viz.formats import RECORDING_SUFFIXES, VIDEO_SUFFIXES, check_suffix
from harness.viz.render import use_offscreen_gl
from harness.writes import check_target


def main(args: argparse.Namespace) -> int:
    # /dev/full, a FIFO, a link: refused first (whatever its name), before the episode runs
    for target in (args.record, args.video, args.video and Path(args.video).with_suffix(".png")):
        if target:
            check_target(Path(target))
    if args.record:
        check_suffix(args.record, RECORDING_SUFFIXES, "--record")
    if args.video:
        check_suffix(args.video, VIDEO_SUFFIXES, "--video")
    use_offscreen_gl()  # before mujoco is first imported
    from harness.episode import run_episode
    from harness.runs.replay import find_episode, row_differences
    from harness.viz.headline import headline

    console = make_console()
    run_dir = Path(args.run_dir)
    spec, stored = find_episode(run_dir, args.episode_id)
    for target in (args.record, args.video):  # their folders, once the episode is found
        if target:
            Path(target).parent.mkdir(parents=True, exist_ok=True)
    console.print(f"replaying {args.episode_id} (seed {spec.seed}) ...", highlight=False)
    result = run_episode(spec)
    differences = row_differences(stored, result.row)
    outcome = headline(result.row)
    if differences:
        console.print(
            styled("[red]the replay differs from the stored row[/] ({outcome}):", outcome=outcome)
        )
        for line in differences:
            console.print(f"  {line}", highlight=False, markup=False)
    else:
        console.print(f"row reproduced exactly ({outcome})", highlight=False)
    if args.record:
        from harness.viz.recording import record_episode

        path = record_episode(result, Path(args.record), spec.task)
        console.print(f"  recording {path}", highlight=False)
    if args.video:
        from harness.viz.video import write_episode_video

        frames = write_episode_video(result, Path(args.video))
        poster = Path(args.video).with_suffix(".png")
        console.print(
            f"  video     {args.video} ({frames} frames; poster {poster})", highlight=False
        )
    return 1 if differences else 0
