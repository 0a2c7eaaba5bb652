"""``autorig preview``: a rig file drawn to a PNG (``autorig.show.preview``)."""
from __future__ import annotations

from pathlib import Path

import click

from ..quiet import quiet_libraries
from .common import (RIG_AXES, check_output, common_options, exit_codes, joint_count, preview_title, refuse_input,
                     require_matplotlib, rig_axes)


FILE_VERTICES = "vertices in the file"   # a glTF's, split where UVs or normals differ: not the input mesh's


@click.command("preview", epilog=exit_codes(2, 4, 9), short_help="Draw a rig file to a PNG.")
@click.argument("rig_file", metavar="RIG")
@click.option("-o", "--output", metavar="PATH",
              help="Where to write the PNG. [default: beside RIG, e.g. hero.rigged.glb -> hero.rigged.png]")
@click.option("--up", type=click.Choice(RIG_AXES, case_sensitive=False),
              help="The rig's up axis. [default: the axes autorig recorded in the file, else y]")
@click.option("--front", type=click.Choice(RIG_AXES, case_sensitive=False),
              help="The axis the character faces. [default: the file's recorded axes, else z]")
@click.option("--title", metavar="TEXT", help="The picture's heading. [default: file name, template, counts]")
@click.option("-q", "--quiet", is_flag=True, help="Print nothing on success.")
@common_options
def preview_command(rig_file: str, output: str | None, up: str | None, front: str | None, title: str | None,
                    quiet: bool):
    """Draw the skinned mesh in RIG (.glb or .gltf, e.g. autorig's output) to a PNG: front and side views
    coloured by each vertex's strongest joint, the skeleton and joint names over them. Needs matplotlib
    (pip install 'autorig[preview]')."""
    require_matplotlib("autorig preview")
    from ..exchange.gltf import read_glb
    from ..show.preview import render_preview

    rig_path = Path(rig_file)
    out_path = Path(output) if output else rig_path.with_suffix(".png")
    refuse_input(out_path, rig_path)
    check_output(out_path, "png")
    with quiet_libraries(shown=False):
        rig = read_glb(rig_path)
        up, front = rig_axes(rig, up, front)
        heading = title if title is not None else preview_title(rig_path.name, rig, FILE_VERTICES)
        render_preview(rig, out_path, title=heading, up=up, front=front)
    if not quiet:
        click.echo(f"{rig_file}: {joint_count(rig)}, {len(rig.vertices)} {FILE_VERTICES} -> {out_path}")
