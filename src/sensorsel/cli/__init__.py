"""The ``sensorsel`` command line: a click group, one module per command group.

Commands only load inputs, call one pipeline function and save; bad input becomes one line on stderr
and exit code 2 (see :func:`sensorsel.cli.options.run`).
"""

from __future__ import annotations

import click

from sensorsel import __version__
from sensorsel.cli import certify, core, kitti, osm, require, resilient, robust, select, simulate, study, vocabulary


@click.group(context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100})
@click.version_option(__version__, prog_name="sensorsel")
def cli() -> None:
    """Choose and place autonomous-vehicle sensors by the SLAM information they give.

    Every command runs on the bundled synthetic route unless given one: --seq NN (real KITTI ground
    truth, with --kitti-root or $SENSORSEL_KITTI_ROOT), --route FILE (your own drive: KITTI poses, a
    TUM trajectory or a planar CSV) or --domain FILE (many routes, one suite). `sensorsel COMMAND
    --help` lists each command's options; every command names a shared option the same way
    (`sensorsel help options`): -o/--output FILE, --output-dir DIRECTORY, --json, -q.
    """


for _module in (core, select, require, resilient, robust, simulate, certify, study, osm, kitti, vocabulary):
    for _command in _module.COMMANDS:
        cli.add_command(_command)


def main() -> None:
    cli(prog_name="sensorsel")
