"""``sensorsel kitti``: the KITTI folder the tool reads (poses, times, pole maps as landmarks/NN.csv in
the route's frame), built from KITTI odometry's download and PRBonn/pole-localization's pole maps
(docs/guide-data.md)."""

from __future__ import annotations

import click

from sensorsel.cli.common import echo_written
from sensorsel.cli.options import output_option, path_option, result_options
from sensorsel.cli.vocabulary import Command


@click.command(
    "kitti", cls=Command, short_help="Build the KITTI folder (routes and pole maps) from the downloaded sources."
)
@path_option(
    "--odometry",
    folder=True,
    required=True,
    help="KITTI odometry's dataset/ folder: poses/NN.txt, sequences/NN/times.txt and sequences/NN/calib.txt "
    "(data_odometry_poses and data_odometry_calib).",
)
@path_option(
    "--poles",
    folder=True,
    required=True,
    help="A clone of PRBonn/pole-localization, or the folder holding its kitti_label_NN/globalmap_gt_cluster.npz.",
)
@click.option(
    "--seq",
    "seqs",
    multiple=True,
    metavar="NN",
    help="A KITTI odometry sequence to build (repeatable; default: every one with both a pose file and a pole map).",
)
@output_option(
    folder=True,
    required=True,
    help="The KITTI folder to write (poses/, sequences/NN/times.txt, landmarks/NN.csv); may be --odometry itself.",
)
@result_options
def kitti_cmd(odometry: str, poles: str, seqs: tuple[str, ...], outdir: str, as_json: bool, quiet: bool) -> None:
    """Build the folder --kitti-root and $SENSORSEL_KITTI_ROOT point at, from what a user downloads:

        sensorsel kitti --odometry dataset/ --poles pole-localization/ --output-dir kitti/

    Each pole of PRBonn's map (x, y in the Velodyne frame of the first scan) is taken by the sequence's
    calibration Tr into camera-0 coordinates p, then into the route's planar frame as (p_z, -p_x),
    written to landmarks/NN.csv in metres with 3 decimals. Every source is checked before anything
    is written: a bad file is refused with one line naming it, and so is a pole map that does not lie
    along its route (another sequence's map or calibration).
    """
    from sensorsel.model.scenario.kitti_sources import build_kitti_folder, find_sources

    wanted = [x.strip() for s in seqs for x in s.split(",") if x.strip()] or None
    if seqs and wanted is None:
        raise click.BadParameter("give a sequence (e.g. --seq 03 --seq 00)", param_hint="--seq")
    built = build_kitti_folder(find_sources(odometry, poles, wanted), outdir)
    if as_json:
        echo_written(
            "kitti",
            folder=outdir,
            sequences=[
                {
                    "seq": b.seq,
                    "frames": b.frames,
                    "poles": b.poles,
                    "median_distance_m": b.median_distance_m,
                    "landmarks": str(b.landmarks),
                }
                for b in built
            ],
        )
        return
    for b in built:
        click.echo(
            f"{b.seq}  {b.frames:>5} frames  {b.poles:>4} poles (median {b.median_distance_m:.1f} m from the "
            f"route)  wrote {b.landmarks}"
        )


COMMANDS = [kitti_cmd]
