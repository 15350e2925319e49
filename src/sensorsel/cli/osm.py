"""``sensorsel osm``: an operating domain from an OpenStreetMap extract (and a GPS track or a
georeferenced route), for a city the fleet has not driven yet (docs/guide-new-city.md)."""

from __future__ import annotations

import shlex
import sys
import warnings
from pathlib import Path

import click

from sensorsel.cli.common import echo_written
from sensorsel.cli.options import osm_reach_option, output_option, path_option, rate_option, result_options, running
from sensorsel.cli.progress import progress_bar
from sensorsel.cli.vocabulary import Command
from sensorsel.errors import InputError, SensorselWarning
from sensorsel.io.progress import report
from sensorsel.io.resources import sample_osm_dir, sample_osm_names
from sensorsel.model.scenario import DEFAULT_OSM_REACH_M


def _source(file: str | None, sample: str | None) -> Path:
    if (file is None) == (sample is None):
        raise click.UsageError("give an OSM extract FILE or --sample NAME (one of them)")
    if sample is not None:
        if sample not in sample_osm_names():
            raise InputError(
                f"--sample {sample!r}: unknown sample city; bundled: {', '.join(sample_osm_names()) or 'none'}"
            )
        return sample_osm_dir() / f"{sample}.osm.pbf"
    return Path(str(file))


@click.command("osm", cls=Command, short_help="An operating domain (routes + landmarks) from an OpenStreetMap extract.")
@click.argument("file", required=False, type=click.Path(dir_okay=False, path_type=str))
@click.option("--sample", default=None, metavar="NAME", help="A bundled sample city instead of FILE (helsinki).")
@click.option("--bbox", default=None, metavar="W,S,E,N", help="Only this box [degrees] of the extract.")
@click.option(
    "--roads",
    default=None,
    metavar="KINDS",
    help="OSM highway kinds to drive, comma-separated (default: primary,secondary,tertiary,unclassified,"
    "residential,living_street; each with its _link).",
)
@click.option(
    "--osm-classes",
    default=None,
    metavar="CLASSES",
    help="Landmark classes, comma-separated, or all (default): street_lamp,utility_pole,power_pole,flagpole,"
    "tree,traffic_signals,stop,give_way,traffic_sign.",
)
@click.option("--speed", "speed_kmh", type=float, default=30.0, show_default=True, help="Driving speed [km/h].")
@click.option("--route-km", type=float, default=1.0, show_default=True, help="Length of one route of the domain [km].")
@osm_reach_option(
    "A route's landmarks: those within this distance of the route [m].", default=DEFAULT_OSM_REACH_M, show_default=True
)
@rate_option("every route")
@path_option(
    "--gpx",
    help="Instead of the road network: this GPS track is the one route (its landmarks from the extract).",
)
@path_option(
    "--route",
    "route_file",
    help="Instead of the road network: this route file (KITTI, TUM or planar CSV) with --georef.",
)
@click.option(
    "--georef",
    default=None,
    metavar="LAT,LON,BEARING|utm:ZONE",
    help="Where --route lies: its origin [deg] and the compass bearing of its +X axis, or utm:35N when its "
    "x, y are UTM easting and northing.",
)
@path_option(
    "--merge-landmarks",
    help="A survey landmark CSV (x,y in the route's frame) merged with the OSM landmarks (--gpx/--route).",
)
@output_option(
    folder=True, required=True, help="Domain folder to write (domain.yaml, routes/, landmarks.csv, README.md)."
)
@result_options
def osm_cmd(
    file: str | None,
    sample: str | None,
    bbox: str | None,
    roads: str | None,
    osm_classes: str | None,
    speed_kmh: float,
    route_km: float,
    osm_reach_m: float,
    keyframe_rate_hz: float,
    gpx: str | None,
    route_file: str | None,
    georef: str | None,
    merge_landmarks: str | None,
    outdir: str,
    as_json: bool,
    quiet: bool,
) -> None:
    """Write an operating domain for a city from its OpenStreetMap extract (.osm or .osm.pbf, read
    locally): routes along the selected roads that drive every one of them (weighted by length),
    keyframes at --speed, and the OSM pole-like landmarks by class. Every --domain command reads it:

        sensorsel osm --sample helsinki --output-dir city/ && sensorsel greedy --domain city/domain.yaml --budget 110000

    With --gpx TRACK or --route FILE --georef ..., the domain is that one route with the extract's
    landmarks near it (and --merge-landmarks' survey). Prints landmarks per km of road per class and
    warns when the map looks sparse. Nothing is written when an input is bad.
    """
    from sensorsel.model.osm.city import build_city, density_table, sparse_warning, write_city
    from sensorsel.model.osm.extract import parse_bbox, parse_classes, parse_roads, read_osm

    path = _source(file, sample)
    box = parse_bbox(bbox) if bbox is not None else None
    classes = parse_classes(osm_classes)
    kinds = parse_roads(roads)
    for name, v in (
        ("--speed", speed_kmh),
        ("--route-km", route_km),
        ("--osm-reach", osm_reach_m),
        ("--rate", keyframe_rate_hz),
    ):
        if not (v == v and 0 < v < float("inf")):
            raise InputError(f"{name} {v!r}: expected a positive number")
    if (route_file is None) != (georef is None):
        raise click.UsageError("--route and --georef go together")
    if gpx is not None and route_file is not None:
        raise click.UsageError("give --gpx or --route, not both")
    if merge_landmarks is not None and gpx is None and route_file is None:
        raise click.UsageError(
            "--merge-landmarks goes with --gpx or --route (a road-network domain has only OSM landmarks)"
        )
    command = "sensorsel " + " ".join(shlex.quote(a) for a in sys.argv[1:]) if sys.argv[1:] else "sensorsel osm"
    if gpx is not None or route_file is not None:
        from sensorsel.model.osm.track import track_domain

        domain, notes = track_domain(
            path,
            box,
            classes,
            kinds,
            gpx,
            route_file,
            georef,
            merge_landmarks,
            speed_kmh,
            osm_reach_m,
            keyframe_rate_hz,
            outdir,
            command,
        )
        for note in notes:
            click.echo(f"sensorsel: note: {note}", err=True)
        if as_json:
            echo_written("osm", domain=str(domain), notes=list(notes))
        else:
            click.echo(f"wrote {domain}")
        return
    # three stages that can each take a while on a large extract: say which one runs (a status line
    # off a terminal as each starts, once the run has gone on for a few seconds)
    bar, progress = progress_bar(quiet or as_json, "osm", counted=False, eta=False)
    with running(bar):
        report(progress, 0, 3, f"reading {path.name}")
        extract = read_osm(path, bbox=box, roads=kinds)
        report(progress, 1, 3, f"routes that drive every road of {len(extract.ways):,} ways")
        city = build_city(extract, classes, speed_kmh=speed_kmh, route_km=route_km, reach_m=osm_reach_m)
        report(progress, 2, 3, f"writing {len(city.routes)} routes")
        domain = write_city(city, extract, outdir, command=command, keyframe_rate_hz=keyframe_rate_hz)
        report(progress, 3, 3, f"wrote {len(city.routes)} routes")
    for note in (*extract.notes, *city.notes):
        click.echo(f"sensorsel: note: {note}", err=True)
    warn = sparse_warning(city)
    if warn:
        warnings.warn(warn, SensorselWarning, stacklevel=1)
    if as_json:
        echo_written(
            "osm",
            domain=str(domain),
            road_km=city.road_m / 1000,
            driven_km=city.driven_m / 1000,
            routes=len(city.routes),
            landmarks={c: {"count": n, "per_km": v} for c, n, v in density_table(city)},
        )
        return
    click.echo(
        f"city       {path}: {city.road_m / 1000:.2f} km of road "
        f"({', '.join(k for k in kinds if not k.endswith('_link'))}), "
        f"{len(city.routes)} routes, {city.driven_m / 1000:.2f} km driven at {speed_kmh:g} km/h"
    )
    click.echo(f"{'class':<16} {'landmarks':>9} {'per km':>7}")
    for c, n, v in density_table(city):
        click.echo(f"{c:<16} {n:>9} {v:>7.1f}")
    click.echo(f"wrote {domain} (Data © OpenStreetMap contributors, ODbL 1.0)")


COMMANDS = [osm_cmd]
