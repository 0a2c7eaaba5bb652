"""``autorig pose``: a rig file moved with a BVH motion (``autorig.show.pose``)."""
from __future__ import annotations

from pathlib import Path

import click

from ..quiet import quiet_libraries
from .common import RIG_AXES, check_output, common_options, exit_codes, refuse_input, rig_axes

# Under this share of the rig's joints (tips aside) a motion leaves most of the body in its rest pose.
DRIVEN_SHARE = 0.5


@click.command("pose", epilog=exit_codes(2, 4, 6), short_help="Move a rig file with a BVH motion.")
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
@click.option("--strict", is_flag=True,
              help=f"Write nothing and exit with code 6 when the motion drives fewer than {DRIVEN_SHARE:.0%} of the "
                   f"rig's joints (its tips aside); without it, a warning.")
@click.option("-q", "--quiet", is_flag=True, help="Print nothing on success (warnings still).")
@common_options
def pose_command(rig_file: str, motion: str, output: str | None, frame: int | None, dqs: bool,
                 map_file: str | None, up: str | None, front: str | None, strict: bool, quiet: bool):
    """Retarget the BVH motion onto the rig in RIG (.glb or .gltf, e.g. autorig's output) by joint names and
    write the rig animated (.glb: each joint's rotation and the root's translation, at the motion's frame
    times), or one frame's deformed mesh (--frame N, .obj). Motion is scaled to the rig's hip height.

    On success prints one line: how many of the rig's joints the motion drives, the frames, and the output
    path. A motion that drives fewer than half of them (a human motion on a cow) gets a warning, or with
    --strict fails.
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

    _check_kinds(rig_path, motion_path)
    with quiet_libraries(shown=False):
        rig = read_glb(rig_path)
        up, front = rig_axes(rig, up, front)
        moves = read_bvh(motion_path)
        if frame is not None and frame >= len(moves.frames):
            raise click.BadParameter(f"{frame}: the motion has {len(moves.frames)} frames (0 to "
                                     f"{len(moves.frames) - 1})", param_hint="'--frame'")
        mapping = joint_map(rig.names, moves.names, read_map(map_file) if map_file else None)
        driven = _driven(rig, mapping)
        if driven[0] < DRIVEN_SHARE * driven[1]:
            _too_few(motion, driven, strict)
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
        click.echo(f"{motion}: drives {driven[0]} of the rig's {driven[1]} joints{driven[2]}, {what} -> {out_path}")


def _driven(rig, mapping: dict) -> tuple[int, int, str]:
    """(joints the motion drives, the rig's joints, " (and its 5 tips)"): tips, joints with no child, have no
    bone of their own to turn and are not counted."""
    parents = set(int(p) for p in rig.parents)
    bones = [name for j, name in enumerate(rig.names) if j in parents]
    tips = len(rig.names) - len(bones)
    return (sum(name in mapping for name in bones), len(bones),
            f" (its {tips} tip{'s' * (tips != 1)} aside)" if tips else "")


def _too_few(motion: str, driven: tuple[int, int, str], strict: bool) -> None:
    """Warn (or with ``strict`` fail, exit 6) that the motion drives too few of the rig's joints."""
    from ..errors import LowConfidenceError
    problem = (f"{motion} drives only {driven[0]} of the rig's {driven[1]} joints{driven[2]}, under "
               f"{DRIVEN_SHARE:.0%}: the others keep their rest pose (a motion made for another skeleton? map "
               f"its joints with --map)")
    if strict:
        raise LowConfidenceError(f"{problem}; nothing written")
    click.echo(f"autorig: warning: {problem}", err=True)


def _check_kinds(rig_path: Path, motion_path: Path) -> None:
    """Say what a rig or motion file is when it is the wrong kind (a mesh given as the rig, a mesh or a glTF
    given as the motion), before its reader fails with what it could not parse."""
    from ..errors import InputError
    from ..input.sniff import MESH_KINDS, file_kind
    kind = file_kind(rig_path)
    if kind in MESH_KINDS or kind == "a BVH motion":
        hint = f": rig it first (autorig {rig_path}) and pose the .glb it writes" if kind in MESH_KINDS else ""
        raise InputError(f"{rig_path} is {kind}, not a rig (a skinned .glb or .gltf){hint}")
    kind = file_kind(motion_path)
    if kind is not None and kind != "a BVH motion":
        raise InputError(f"{motion_path} is {kind}, not a BVH motion (-m takes a .bvh file)")
