"""``sensorsel kitti``: the KITTI folder the tool reads (poses, times, pole maps as landmarks/NN.csv in
the route's frame), built from KITTI odometry's download and PRBonn/pole-localization's pole maps
(docs/guide-data.md)."""

from __future__ import annotations

import click

from sensorsel.cli.options import output_option, run


@click.command("kitti", short_help="Build the KITTI folder (routes and pole maps) from the downloaded sources.")
@click.option("--odometry", required=True, type=click.Path(file_okay=False, path_type=str),
              help="KITTI odometry's dataset/ folder: poses/NN.txt, sequences/NN/times.txt and sequences/NN/calib.txt "
                   "(data_odometry_poses and data_odometry_calib).")
@click.option("--poles", required=True, type=click.Path(file_okay=False, path_type=str),
              help="A clone of PRBonn/pole-localization, or the folder holding its kitti_label_NN/globalmap_gt_cluster.npz.")
@click.option("--seq", "seqs", default=None, metavar="NN[,NN...]",
              help="Sequences to build (default: every one with both a pose file and a pole map).")
@output_option(folder=True, required=True,
               help="The KITTI folder to write (poses/, sequences/NN/times.txt, landmarks/NN.csv); may be --odometry itself.")
@run
def kitti_cmd(odometry: str, poles: str, seqs: str | None, output: str) -> None:
    """Build the folder --kitti-root and $SENSORSEL_KITTI_ROOT point at, from what a user downloads:

        sensorsel kitti --odometry dataset/ --poles pole-localization/ -o kitti/

    Each pole of PRBonn's map (x, y in the Velodyne frame of the first scan) is taken by the sequence's
    calibration Tr into camera-0 coordinates p, then into the route's planar frame as (p_z, -p_x),
    written to landmarks/NN.csv in metres with 3 decimals. Every source is checked before anything
    is written: a bad file is refused with one line naming it, and so is a pole map that does not lie
    along its route (another sequence's map or calibration).
    """
    from sensorsel.model.scenario.kitti_sources import build_kitti_folder, find_sources

    wanted = None if seqs is None else [s.strip() for s in seqs.split(",") if s.strip()]
    if wanted is not None and not wanted:
        raise click.BadParameter("give at least one sequence (e.g. 03 or 00,03)", param_hint="--seq")
    for b in build_kitti_folder(find_sources(odometry, poles, wanted), output):
        click.echo(f"{b.seq}  {b.frames:>5} frames  {b.poles:>4} poles (median {b.median_distance_m:.1f} m from the "
                   f"route)  wrote {b.landmarks}")


COMMANDS = [kitti_cmd]
