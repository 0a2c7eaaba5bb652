"""``autorig pose``: a rig file moved with a BVH motion (``autorig.show.pose``)."""
from __future__ import annotations

from pathlib import Path

import click

from ..quiet import quiet_libraries
from .common import EXIT_CODES, RIG_AXES, check_output, common_options, refuse_input, rig_axes


@click.command("pose", epilog=EXIT_CODES, short_help="Move a rig file with a BVH motion.")
@click.argument("rig_file", metavar="RIG")
@click.option("-m", "--motion", required=True, metavar="BVH", help="The motion to retarget (.bvh).")
@click.option("-o", "--output", metavar="PATH",
              help="The animated rig (.glb), or with --frame the posed mesh (.obj). [default: beside RIG, "
                   "e.g. hero.rigged.walk.glb, hero.rigged.walk.12.obj]")
@click.option("--frame", type=click.IntRange(min=0), metavar="N",
              help="Write only frame N (from 0) of the motion, as a deformed mesh.")
@click.option("--dqs", is_flag=True,
              help="With --frame: dual quaternion skinning (keeps twisted joints' volume) instead of linear "
                   "blend skinning, which is what glTF viewers do.")
@click.option("--map", "map_file", metavar="JSON",
              help="Joint map file {rig joint: motion joint, or null}, applied over the built-in table "
                   "(CMU and mixamo names, for the biped and humanoid templates).")
@click.option("--up", type=click.Choice(RIG_AXES, case_sensitive=False),
              help="The rig's up axis. [default: the axes autorig recorded in the file, else y]")
@click.option("--front", type=click.Choice(RIG_AXES, case_sensitive=False),
              help="The axis the character faces. [default: the file's recorded axes, else z]")
@click.option("-q", "--quiet", is_flag=True, help="Print nothing on success.")
@common_options
def pose_command(rig_file: str, motion: str, output: str | None, frame: int | None, dqs: bool,
                 map_file: str | None, up: str | None, front: str | None, quiet: bool):
    """Retarget the BVH motion onto the rig in RIG (.glb or .gltf, e.g. autorig's output) by joint names and
    write the rig animated (.glb: each joint's rotation and the root's translation, at the motion's frame
    times), or one frame's deformed mesh (--frame N, .obj). Motion is scaled to the rig's hip height.

    On success prints one line: how many joints were mapped, the frames, and the output path.
    """
    if dqs and frame is None:
        raise click.UsageError("--dqs applies to --frame: an animated glTF is skinned by its viewer")
    suffix = ".obj" if frame is not None else ".glb"
    rig_path, motion_path = Path(rig_file), Path(motion)
    if output is None:
        stem = f"{rig_path.stem}.{motion_path.stem}" + (f".{frame}" if frame is not None else "")
        out_path = rig_path.with_name(stem + suffix)
    else:
        out_path = Path(output)
        if out_path.suffix.lower() != suffix:
            raise click.UsageError(f"cannot write {output!r}: the animated rig is a .glb file, a single frame "
                                   f"(--frame N) an .obj file")
    for source in (rig_path, motion_path):
        refuse_input(out_path, source)
    check_output(out_path, suffix.lstrip("."))

    from ..exchange.bvh import read_bvh
    from ..exchange.gltf import read_glb
    from ..show.pose import joint_map, read_map, retarget

    with quiet_libraries(shown=False):
        rig = read_glb(rig_path)
        up, front = rig_axes(rig, up, front)
        moves = read_bvh(motion_path)
        if frame is not None and frame >= len(moves.frames):
            raise click.BadParameter(f"{frame}: the motion has {len(moves.frames)} frames (0 to "
                                     f"{len(moves.frames) - 1})", param_hint="'--frame'")
        mapping = joint_map(rig.names, moves.names, read_map(map_file) if map_file else None)
        animation = retarget(rig, moves, mapping, up=up, front=front)
        if frame is None:
            from ..exchange.animated_gltf import write_animated_glb
            write_animated_glb(rig, animation, out_path, name=motion_path.stem)
        else:
            from ..exchange.obj import write_obj
            from ..show.pose import skin
            write_obj(skin(rig, animation.rotations[frame], animation.positions[frame], dqs=dqs), rig.faces,
                      out_path)
    if not quiet:
        what = f"frame {frame} of {len(moves.frames)}" if frame is not None else f"{len(moves.frames)} frames"
        click.echo(f"{motion}: {len(mapping)} of {len(rig.names)} rig joints mapped, {what} -> {out_path}")
