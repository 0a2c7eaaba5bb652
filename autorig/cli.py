"""The ``autorig`` command line.

    autorig hero.obj                        # rig with the biped template -> hero.rigged.glb
    autorig hero.obj --template quadruped -o out/hero.json
    autorig hero.obj --skeleton my_rig.glb  # weights only, for your own skeleton (.json, .glb/.gltf, .bvh)
    autorig rig hero.obj ...                # the same: ``rig`` is the default command
    autorig templates                       # list the built-in templates
    autorig batch assets/ -o rigged/        # every mesh in a folder (autorig.batch)
    autorig hero.obj --preview              # also hero.rigged.png: front and side views (autorig.preview)
    autorig preview hero.rigged.glb         # the same picture of an existing rig
    autorig pose hero.rigged.glb -m walk.bvh -o walk.glb    # retarget a BVH motion (autorig.pose)
    autorig learn rigs/*.glb -o studio.json                 # a template learned from rigged characters

Start-up must stay fast (``autorig --help`` well under 0.3 s): at module level import only click, the standard
library and ``autorig``'s own light modules; numpy, trimesh, libigl and the pipeline load inside the commands.
"""
from __future__ import annotations

import gc
import os
import sys
import time
import traceback
from pathlib import Path

import click

from .version import __version__
from .errors import AutorigError, OutputError
from .quiet import quiet_libraries

AXES = ["auto", "x", "y", "z", "-x", "-y", "-z", "+x", "+y", "+z"]
# Must match autorig.exchange.FORMATS (a test checks); repeated here so --help need not import numpy.
FORMATS = ["glb", "gltf", "pinocchio", "json", "usda", "usdc", "usdz", "fbx"]
# Must match autorig.extract.AUTO (a test checks): the template name of template-free skeletons.
AUTO_TEMPLATE = "auto"
FORMAT_OF_SUFFIX = {".glb": "glb", ".gltf": "gltf", ".json": "json", ".usda": "usda", ".usdc": "usdc",
                    ".usdz": "usdz", ".fbx": "fbx"}

EXIT_INTERNAL = 70   # EX_SOFTWARE from BSD sysexits: a bug in autorig
EXIT_INTERRUPTED = 130  # 128 + SIGINT, what shells report for Ctrl-C

EXIT_CODES = """\b
Exit codes:
  0    success
  1    general error
  2    bad input mesh, or a command-line usage error
  3    unknown or malformed template, or a bad --skeleton file
  4    output cannot be written
  5    the mesh was read but could not be rigged
  6    --strict: the rig's confidence is below the threshold (nothing written)
  7    batch: some assets could not be rigged (the others were; see the report)
  70   internal error (a bug: run with --debug and report it)
  130  interrupted (Ctrl-C)"""

_DEBUG = "autorig.debug"  # key in click's ctx.meta, which a group shares with its subcommands

# Shared by 'autorig rig' and 'autorig batch'. NAME_SCHEMES must match autorig.naming.NAME_SCHEMES.
NAME_SCHEMES = ["template", "mixamo"]
NAMES_HELP = ("Joint names in the output: the template's, or mixamo (mixamorig:Hips, mixamorig:LeftUpLeg, ...; "
              "biped only) for animation libraries and Unity's Humanoid auto-mapping.")
VOXELS_HELP = "--template auto: voxels along the mesh's longest side (finer finds thinner limbs)."
MAX_SEGMENTS_HELP = "--template auto: the most bones per chain (limb), plus one for each chain hanging from it."


class DefaultCommandGroup(click.Group):
    """A click group with a default command: when the first argument is not a subcommand name (nor one of the
    group's own options), the whole command line goes to the default command, so ``autorig hero.obj -v`` means
    ``autorig rig hero.obj -v``. (A mesh file literally called ``templates`` needs ``autorig rig templates``.)

    It also turns exceptions into exit codes: an ``AutorigError`` prints ``autorig: error: <message>`` and exits
    with its ``exit_code``; anything else is an internal error (exit 70; ``--debug`` adds the traceback).
    """

    def __init__(self, *args, default_command: str, **kwargs):
        super().__init__(*args, **kwargs)
        self.default_command = default_command

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        own_options = {name for param in self.get_params(ctx) for name in param.opts + param.secondary_opts}
        if args and args[0] not in self.commands and args[0] not in own_options:
            args = [self.default_command, *args]
        return super().parse_args(ctx, args)

    def format_usage(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        formatter.write_usage(ctx.command_path, "MESH [OPTIONS]")
        formatter.write_usage(ctx.command_path, "COMMAND [ARGS]...", prefix="   or: ")

    def invoke(self, ctx: click.Context):
        try:
            return super().invoke(ctx)
        except (click.ClickException, click.exceptions.Exit, click.Abort):
            raise
        except AutorigError as e:
            if ctx.meta.get(_DEBUG):
                traceback.print_exc()
            _error_line(f"autorig: error: {e}")
            ctx.exit(e.exit_code)
        except KeyboardInterrupt:
            _error_line("autorig: interrupted")
            ctx.exit(EXIT_INTERRUPTED)
        except Exception as e:
            if ctx.meta.get(_DEBUG):
                traceback.print_exc()
                _error_line(f"autorig: internal error: {type(e).__name__}: {e}")
            else:
                _error_line(f"autorig: internal error: {type(e).__name__}: {e} (run with --debug for details)")
            ctx.exit(EXIT_INTERNAL)


def _error_line(message: str) -> None:
    """Print ``message`` on stderr as exactly one line, whatever newlines the message carries."""
    click.echo(" ".join(message.split("\n")), err=True)


def _set_debug(ctx: click.Context, _param, value: bool) -> None:
    if value:
        ctx.meta[_DEBUG] = True


_version_option = click.version_option(__version__, "--version", prog_name="autorig", message="%(prog)s %(version)s")


def _common_options(command):
    command = click.option("--debug", is_flag=True, expose_value=False, is_eager=True, callback=_set_debug,
                           help="Show the full traceback of an error.")(command)
    return _version_option(command)


@click.group(cls=DefaultCommandGroup, default_command="rig", epilog=EXIT_CODES,
             context_settings={"help_option_names": ["-h", "--help"]})
@_version_option
def cli():
    """Rig 3D characters automatically: embed a template skeleton in a mesh and compute skin weights.

    \b
      autorig MESH [OPTIONS]    rig a mesh; short for 'autorig rig MESH [OPTIONS]'
                                (see 'autorig rig --help' for the options)
      autorig templates         list the built-in templates
      autorig batch DIR -o OUT  rig every mesh in a folder (see 'autorig batch --help')
      autorig preview RIG       draw a rig file to a PNG
      autorig pose RIG -m BVH   move a rig file with a BVH motion
      autorig learn RIGS -o T   learn a template from rigged characters
    """


@cli.command("rig", epilog=EXIT_CODES, short_help="Rig a mesh (the default command).")
@click.argument("mesh", metavar="MESH")
@click.option("-t", "--template", default="biped", show_default=True, metavar="NAME|PATH",
              help="Built-in template name (see 'autorig templates'), a template .json file, or auto: a "
                   "skeleton made from the mesh's own shape, for creatures no template fits.")
@click.option("-o", "--output", metavar="PATH",
              help="Where to write the rig. [default: beside MESH, e.g. hero.obj -> hero.rigged.glb]")
@click.option("-f", "--format", "fmt", type=click.Choice(FORMATS),
              help="Output format. [default: from -o's extension (.glb, .gltf, .json, .usda/.usdc/.usdz, "
                   ".fbx; no extension: pinocchio folder), else glb]")
@click.option("--up", type=click.Choice(AXES, case_sensitive=False), default="auto", show_default=True,
              help="The mesh's up axis, or auto to detect it.")
@click.option("--front", type=click.Choice(AXES, case_sensitive=False), default="auto", show_default=True,
              help="The axis the character faces, or auto to detect it (glTF's +z unless the shape "
                   "clearly says otherwise).")
@click.option("--strict", is_flag=True,
              help="Write nothing and exit with code 6 when the rig's confidence is below the threshold.")
@click.option("--preview", is_flag=True,
              help="Also draw the rig to a PNG beside the output (hero.rigged.glb -> hero.rigged.png); "
                   "needs matplotlib (pip install 'autorig[preview]').")
@click.option("--voxels", type=click.IntRange(min=8), default=96, show_default=True, metavar="N",
              help=VOXELS_HELP)
@click.option("--max-segments", type=click.IntRange(min=1), default=8, show_default=True, metavar="N",
              help=MAX_SEGMENTS_HELP)
@click.option("-s", "--skeleton", "skeleton_file", metavar="FILE",
              help="Your own skeleton (.json, .glb/.gltf, .bvh): no embedding, only skin weights for its joints.")
@click.option("--skeleton-scale", default=None, metavar="FLOAT|auto",
              help="--skeleton: multiply its positions by FLOAT, or auto: fit it to the mesh's size. "
                   "[default: auto for .bvh, else 1 (positions in the mesh's units)]")
@click.option("--names", type=click.Choice(NAME_SCHEMES), default="template", show_default=True,
              help=NAMES_HELP)
@click.option("-v", "--verbose", is_flag=True, help="Also print each stage's time (on stderr).")
@click.option("-q", "--quiet", is_flag=True, help="Print nothing on success.")
@_common_options
def rig_command(mesh: str, template: str, output: str | None, fmt: str | None, up: str, front: str,
                strict: bool, preview: bool, voxels: int, max_segments: int, skeleton_file: str | None,
                skeleton_scale: str | None, names: str, verbose: bool, quiet: bool):
    """Rig MESH (OBJ, PLY, STL, OFF, glTF/GLB) with a template skeleton and write the result; or, with
    --skeleton, compute skin weights for your own skeleton.

    On success prints one line: the mesh, template, joint and vertex counts, time and output path.
    """
    if verbose and quiet:
        raise click.UsageError("--verbose and --quiet cannot be used together")
    start = time.perf_counter()
    from .mesh import check_mesh_path, frame_rotation
    from .template import load_template

    if skeleton_file is not None or skeleton_scale is not None:
        return _skin_command(mesh, skeleton_file, skeleton_scale, output, fmt, preview, names, verbose, quiet,
                             start)
    mesh_path = check_mesh_path(mesh)
    skeleton = template if template == AUTO_TEMPLATE else load_template(template)
    if names != "template":
        from .naming import check_names
        # A template without Mixamo names fails here, before any slow work.
        check_names(["root"] if skeleton == AUTO_TEMPLATE else list(skeleton.names), names)
    if "auto" not in (up, front):
        frame_rotation(up, front)  # rejects up parallel to front before any slow work
    out_path, fmt = _output_for(mesh_path, output, fmt, preview)

    from .confidence import STRICT_THRESHOLD
    from .errors import LowConfidenceError
    from .pipeline import RigOptions, rig
    with quiet_libraries(shown=verbose):
        _import_paused(RIG_MODULES, fmt)
        result = rig(str(mesh_path), skeleton, RigOptions(up=up, front=front, voxels=voxels,
                                                          max_segments=max_segments))
        confidence = result.info["confidence"]
        if strict and confidence < STRICT_THRESHOLD:
            raise LowConfidenceError(f"{mesh}: confidence {confidence:.2f} is below {STRICT_THRESHOLD} "
                                     f"({_weakest(result.info['confidence_parts'])}); nothing written")
        preview_path = _write(_named(result, names), out_path, fmt, mesh_path, preview, verbose)
    end = time.perf_counter()

    if not quiet:
        axes = f"up {result.info['up']}, front {result.info['front']}"
        if result.info["axes_detected"]:
            axes += " (detected)"
        click.echo(f"{mesh}: {result.template}, {len(result.names)} joints, {len(result.vertices)} vertices, "
                   f"{axes}, confidence {result.info['confidence']:.2f}, {end - start:.2f} s -> {out_path}"
                   + (f" (preview {preview_path})" if preview else ""))


# What each command's pipeline imports (see _import_paused); a module missing here only costs some speed.
RIG_MODULES = ("autorig.pipeline", "autorig.attach", "igl", "scipy.sparse.linalg", "scipy.optimize")
SKIN_MODULES = ("autorig.pipeline", "autorig.attach", "autorig.bones", "igl", "scipy.sparse.linalg")


def _import_paused(modules: tuple[str, ...], fmt: str) -> None:
    """Import ``modules`` and the writer of ``fmt`` with the cyclic garbage collector paused, then freeze them.

    numpy, scipy, libigl and pygltflib make hundreds of thousands of objects that live as long as the process.
    The collector would walk them in each of the ~145 collections their imports trigger, and again when the
    interpreter shuts down: together about 0.1 s of a 1.2 s rig (20k faces, interleaved runs of the whole
    process). Once loaded they are moved out of its sight (``gc.freeze``); what a rig allocates afterwards is
    collected as usual.
    """
    if fmt in ("glb", "gltf"):
        modules = (*modules, "autorig.exchange.gltf")
    if all(module in sys.modules for module in modules):
        return
    import importlib
    was_enabled = gc.isenabled()
    gc.disable()
    try:
        for module in modules:
            importlib.import_module(module)
    finally:
        gc.freeze()
        if was_enabled:
            gc.enable()


def _skin_command(mesh: str, skeleton_file: str | None, skeleton_scale: str | None, output: str | None,
                  fmt: str | None, preview: bool, names: str, verbose: bool, quiet: bool, start: float) -> None:
    """``autorig MESH --skeleton FILE``: weights for the user's skeleton (``autorig.pipeline.skin``)."""
    ctx = click.get_current_context()
    if skeleton_file is None:
        raise click.UsageError("--skeleton-scale applies to --skeleton")
    # Options of the embedding mean nothing here; given explicitly, they are a mistake worth saying.
    for param in ("template", "up", "front", "strict", "voxels", "max_segments"):
        if ctx.get_parameter_source(param) == click.core.ParameterSource.COMMANDLINE:
            raise click.UsageError(f"--{param.replace('_', '-')} does not apply with --skeleton (the skeleton is "
                                   f"given, not embedded)")
    scale = _skeleton_scale(skeleton_scale)

    from .exchange.skeleton import read_skeleton
    from .mesh import check_mesh_path

    mesh_path = check_mesh_path(mesh)
    out_path, fmt = _output_for(mesh_path, output, fmt, preview, Path(skeleton_file))
    with quiet_libraries(shown=verbose):
        skeleton = read_skeleton(skeleton_file)
    if fmt == "pinocchio":
        from .exchange.pinocchio import unfit_skeleton
        problem = unfit_skeleton(skeleton.parents)
        if problem:
            raise click.UsageError(f"--format pinocchio: {skeleton_file}: {problem}")

    from .pipeline import SkinOptions, skin
    with quiet_libraries(shown=verbose):
        _import_paused(SKIN_MODULES, fmt)
        result = skin(str(mesh_path), skeleton, SkinOptions(scale=scale))
        preview_path = _write(_named(result, names), out_path, fmt, mesh_path, preview, verbose)
    end = time.perf_counter()

    if not quiet:
        info = result.info
        cold = sum(map(len, info["cold_bones"].values()))
        click.echo(f"{mesh}: skeleton {skeleton_file}, {len(result.names)} joints ({info['joints_weighted']} "
                   f"weighted, {len(info['tip_bones'])} tip bones, {cold} bones left cold), {len(result.vertices)} "
                   f"vertices, {end - start:.2f} s -> {out_path}" + (f" (preview {preview_path})" if preview else ""))


@cli.command("templates", short_help="List the built-in templates.")
@_common_options
def templates_command():
    """List the built-in templates: name, number of joints, description; and auto, the template-free skeleton."""
    from .template import builtin_description, builtin_names, load_template

    for name in builtin_names():
        joints = len(load_template(name).names)
        click.echo(f"{name:<12} {joints:3d} joints  {builtin_description(name)}")
    click.echo(f"{AUTO_TEMPLATE:<12} any joints  No template: a skeleton made from the mesh's own shape, one chain per "
               f"limb, for any creature (Wade & Parent 2002; see --voxels, --max-segments).")


@cli.command("learn", epilog=EXIT_CODES, short_help="Learn a template from rigged characters.")
@click.argument("rigs", nargs=-1, required=True, metavar="RIGS...")
@click.option("-o", "--output", required=True, metavar="TEMPLATE.json", help="Where to write the template.")
@click.option("-t", "--template", "base", metavar="NAME|PATH",
              help="The template whose joint names corpus folders map to (their joints.json maps); without it "
                   "the rigged glTF files' own joints and hierarchy are learned.")
@click.option("--name", metavar="NAME", help="The learned template's name. [default: the base's, or the file's stem]")
@click.option("--learn", "parts", default="proportions,penalties,placement,confidence", show_default=True,
              metavar="PARTS", help="What to learn (comma-separated, of proportions, penalties, orientation, "
                                    "placement, confidence); with --template the rest is the base's. orientation: "
                                    "how much detection weighs the head/tail cue (four-legged templates).")
@click.option("-q", "--quiet", is_flag=True, help="Print nothing on success.")
@_common_options
def learn_command(rigs: tuple[str, ...], output: str, base: str | None, name: str | None, parts: str,
                  quiet: bool):
    """Learn a template from rigged characters: rest proportions, mirror pairs, feet, fat joints, tips and
    helper joints, the embedding's penalty weights (max margin) and a calibrated confidence.

    \b
    RIGS are rigged .glb/.gltf files sharing one skeleton, or corpus folders (joints.json with a map to the
    --template's joint names, mesh.obj, weights.npz), or folders of either.
      autorig learn studio/*.glb -o studio.json
      autorig learn ../shared/data/train --template quadruped -o quadruped.json
    """
    from .exchange import write_file_atomic
    from .learn import learn_template
    from .template import base_description, load_template, template_json

    out = Path(output)
    if out.suffix.lower() != ".json":
        raise click.UsageError(f"the template is a .json file, not {out.name}")
    if not out.parent.is_dir():
        raise OutputError(f"cannot write {out}: the directory {out.parent} does not exist")
    start = time.perf_counter()
    base_template = load_template(base) if base else None
    progress = None if quiet else (lambda line: click.echo(f"  {line}", err=True))
    learned = learn_template(list(rigs), base=base_template, name=name or (None if base else out.stem),
                             progress=progress, parts=[p.strip() for p in parts.split(",") if p.strip()])
    description = (base_description(base) + " " if base else "") + \
        f"Learned by autorig learn from {len(learned.examples)} rigged characters."
    write_file_atomic(out, template_json(learned.template.to_dict(description)).encode())
    if not quiet:
        t = learned.template
        click.echo(f"{t.name}: {len(t.names)} joints, {len(t.helpers)} helpers, from {len(learned.examples)} "
                   f"examples in {time.perf_counter() - start:.1f} s -> {out}")


# Axes of an existing rig file: the file does not record them, so no detection.
RIG_AXES = [axis for axis in AXES if axis != "auto"]


@cli.command("preview", epilog=EXIT_CODES, short_help="Draw a rig file to a PNG.")
@click.argument("rig_file", metavar="RIG")
@click.option("-o", "--output", metavar="PATH",
              help="Where to write the PNG. [default: beside RIG, e.g. hero.rigged.glb -> hero.rigged.png]")
@click.option("--up", type=click.Choice(RIG_AXES, case_sensitive=False), default="y", show_default=True,
              help="The rig's up axis.")
@click.option("--front", type=click.Choice(RIG_AXES, case_sensitive=False), default="z", show_default=True,
              help="The axis the character faces.")
@click.option("--title", metavar="TEXT", help="The picture's heading. [default: file name, template, counts]")
@click.option("-q", "--quiet", is_flag=True, help="Print nothing on success.")
@_common_options
def preview_command(rig_file: str, output: str | None, up: str, front: str, title: str | None, quiet: bool):
    """Draw the skinned mesh in RIG (.glb or .gltf, e.g. autorig's output) to a PNG: front and side views
    coloured by each vertex's strongest joint, the skeleton and joint names over them. Needs matplotlib
    (pip install 'autorig[preview]')."""
    _require_matplotlib("autorig preview")
    from .exchange.gltf import read_glb
    from .mesh import frame_rotation
    from .preview import render_preview

    frame_rotation(up, front)
    rig_path = Path(rig_file)
    out_path = Path(output) if output else rig_path.with_suffix(".png")
    _refuse_input(out_path, rig_path)
    _check_output(out_path, "png")
    with quiet_libraries(shown=False):
        rig = read_glb(rig_path)
        render_preview(rig, out_path, title=title if title is not None else _preview_title(rig_path.name, rig),
                       up=up, front=front)
    if not quiet:
        click.echo(f"{rig_file}: {len(rig.names)} joints, {len(rig.vertices)} vertices -> {out_path}")


@cli.command("pose", epilog=EXIT_CODES, short_help="Move a rig file with a BVH motion.")
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
                   "(CMU and mixamo names, for the biped template).")
@click.option("--up", type=click.Choice(RIG_AXES, case_sensitive=False), default="y", show_default=True,
              help="The rig's up axis.")
@click.option("--front", type=click.Choice(RIG_AXES, case_sensitive=False), default="z", show_default=True,
              help="The axis the character faces.")
@click.option("-q", "--quiet", is_flag=True, help="Print nothing on success.")
@_common_options
def pose_command(rig_file: str, motion: str, output: str | None, frame: int | None, dqs: bool,
                 map_file: str | None, up: str, front: str, quiet: bool):
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
        _refuse_input(out_path, source)
    _check_output(out_path, suffix.lstrip("."))

    from .exchange.bvh import read_bvh
    from .exchange.gltf import read_glb
    from .mesh import frame_rotation
    from .pose import joint_map, read_map, retarget

    frame_rotation(up, front)
    with quiet_libraries(shown=False):
        rig = read_glb(rig_path)
        moves = read_bvh(motion_path)
        if frame is not None and frame >= len(moves.frames):
            raise click.BadParameter(f"{frame}: the motion has {len(moves.frames)} frames (0 to "
                                     f"{len(moves.frames) - 1})", param_hint="'--frame'")
        mapping = joint_map(rig.names, moves.names, read_map(map_file) if map_file else None)
        animation = retarget(rig, moves, mapping, up=up, front=front)
        if frame is None:
            from .exchange.animated_gltf import write_animated_glb
            write_animated_glb(rig, animation, out_path, name=motion_path.stem)
        else:
            from .exchange.obj import write_obj
            from .pose import skin
            write_obj(skin(rig, animation.rotations[frame], animation.positions[frame], dqs=dqs), rig.faces,
                      out_path)
    if not quiet:
        what = f"frame {frame} of {len(moves.frames)}" if frame is not None else f"{len(moves.frames)} frames"
        click.echo(f"{motion}: {len(mapping)} of {len(rig.names)} rig joints mapped, {what} -> {out_path}")


# Must match autorig.batch.DEFAULT_EXTENSIONS (a test checks); repeated here so --help imports nothing.
BATCH_EXTENSIONS = "obj,off,ply,stl,glb,gltf"


@cli.command("batch", epilog=EXIT_CODES, short_help="Rig every mesh in a folder.")
@click.argument("input_dir", metavar="INPUT_DIR")
@click.option("-o", "--output", "output_dir", required=True, metavar="OUTPUT_DIR",
              help="Folder for the rigs; INPUT_DIR's folder structure is mirrored inside it.")
@click.option("-t", "--template", default="biped", show_default=True, metavar="NAME|PATH",
              help="Template for assets that no autorig.toml gives a template or skeleton: a built-in name, a "
                   "template .json file, or auto (a skeleton made from each mesh's own shape).")
@click.option("-s", "--skeleton", "skeleton_file", metavar="FILE",
              help="Your own skeleton (.json, .glb/.gltf, .bvh), instead of --template, for assets that no "
                   "autorig.toml gives a template or skeleton: only skin weights for its joints.")
@click.option("--skeleton-scale", default=None, metavar="FLOAT|auto",
              help="Assets with a skeleton (from --skeleton or autorig.toml): multiply its positions by FLOAT, or "
                   "auto: fit it to the mesh's size. [default: auto for .bvh, else 1 (positions in the mesh's "
                   "units)]")
@click.option("--up", type=click.Choice(AXES, case_sensitive=False), default="auto", show_default=True,
              help="Up axis for assets that no autorig.toml gives one (not for skeleton assets).")
@click.option("--front", type=click.Choice(AXES, case_sensitive=False), default="auto", show_default=True,
              help="Front axis for assets that no autorig.toml gives one (not for skeleton assets).")
@click.option("--voxels", type=click.IntRange(min=8), default=96, show_default=True, metavar="N",
              help=VOXELS_HELP)
@click.option("--max-segments", type=click.IntRange(min=1), default=8, show_default=True, metavar="N",
              help=MAX_SEGMENTS_HELP)
@click.option("-f", "--format", "fmt", type=click.Choice(FORMATS), default="glb", show_default=True,
              help="Output format.")
@click.option("--ext", default=BATCH_EXTENSIONS, show_default=True, metavar="EXT,...",
              help="File extensions that count as meshes.")
@click.option("-j", "--jobs", type=click.IntRange(min=1), metavar="N",
              help="Worker processes. [default: the number of CPUs]")
@click.option("--scheduler", metavar="tcp://HOST:PORT",
              help="Run on this Dask distributed scheduler instead (pip install 'autorig[cluster]').")
@click.option("--force", is_flag=True, help="Rig every asset, even those unchanged since the last run.")
@click.option("--report", metavar="PATH", help="Write a JSON report here.")
@click.option("--junit", metavar="PATH", help="Write a JUnit XML report here (one test case per asset).")
@click.option("--html", metavar="PATH",
              help="Write a page to review the batch by eye here: every rig's front and side thumbnails, doubtful "
                   "ones first (one offline file; needs matplotlib). Also: html = \"PATH\" in INPUT_DIR's "
                   "autorig.toml, relative to OUTPUT_DIR.")
@click.option("--names", type=click.Choice(NAME_SCHEMES), default="template", show_default=True,
              help=NAMES_HELP)
@click.option("-q", "--quiet", is_flag=True, help="Print only failed assets.")
@_common_options
def batch_command(input_dir: str, output_dir: str, template: str, skeleton_file: str | None,
                  skeleton_scale: str | None, up: str, front: str, voxels: int, max_segments: int, fmt: str,
                  ext: str, jobs: int | None, scheduler: str | None, force: bool, report: str | None,
                  junit: str | None, html: str | None, names: str, quiet: bool):
    """Rig every mesh under INPUT_DIR (recursively) into OUTPUT_DIR, in parallel.

    \b
    Options per file or folder come from autorig.toml files beside the assets:
      template = "quadruped"          # this folder and below
      [files."horse*.obj"]            # matching files (globs)
      template = "horse"
      up = "z"
      front = "y"
      [files."hero.obj"]
      skeleton = "hero_rig.glb"       # your own skeleton: only weights
      [files."octopus*"]
      template = "auto"               # a skeleton from the shape itself
    the nearest file winning; template and skeleton replace each other (see the README). Assets unchanged
    since the last run (same content, options and autorig version) are skipped unless --force. A failing
    asset does not stop the others: it is reported, and the exit code is 7. Progress goes to stderr (a bar
    on a terminal, else one line per asset); a summary line to stdout.
    """
    ctx = click.get_current_context()
    if jobs is not None and scheduler:
        raise click.UsageError("-j/--jobs does not apply with --scheduler: the cluster's workers decide")
    if skeleton_file is not None and ctx.get_parameter_source("template") == click.core.ParameterSource.COMMANDLINE:
        raise click.UsageError("--template and --skeleton are alternatives: give one (autorig.toml files may "
                               "still choose either per asset)")
    scale = _skeleton_scale(skeleton_scale)
    extensions = [e.strip().lstrip(".") for e in ext.split(",") if e.strip()]
    from .mesh import FORMATS as MESH_FORMATS
    unknown = sorted({e for e in extensions if "." + e.lower() not in MESH_FORMATS})
    if unknown or not extensions:
        raise click.UsageError(f"--ext: autorig reads {', '.join(s[1:] for s in sorted(MESH_FORMATS))}"
                               + (f", not {', '.join(unknown)}" if unknown else ""))

    from .batch import rig_folder
    from .batch.progress import BatchProgress
    from .pipeline import RigOptions, SkinOptions

    progress = BatchProgress(quiet=quiet)
    try:
        result = rig_folder(input_dir, output_dir, template,
                            RigOptions(up=up.lower(), front=front.lower(), voxels=voxels, max_segments=max_segments),
                            skeleton=skeleton_file, skin_options=SkinOptions(scale=scale), fmt=fmt,
                            extensions=extensions, jobs=jobs, scheduler=scheduler, force=force, report=report,
                            junit=junit, html=html, names=names, on_start=progress.on_start,
                            on_result=progress.on_result)
    finally:
        progress.close()
    if not quiet:
        counts = result.counts
        click.echo(f"{len(result.assets)} assets: {counts['ok']} rigged, {counts['failed']} failed, "
                   f"{counts['skipped']} unchanged, {result.seconds:.1f} s -> {output_dir}")
    ctx.exit(result.exit_code)


def _skeleton_scale(text: str | None) -> float | str | None:
    """``--skeleton-scale``'s value: None (not given), "auto" or a positive number, else a usage error."""
    if text is None:
        return None
    try:
        scale = "auto" if text.lower() == "auto" else float(text)
    except ValueError:
        scale = None
    if scale is None or (scale != "auto" and not (0 < scale < float("inf"))):
        raise click.BadParameter(f"{text!r} is not a positive number or auto", param_hint="'--skeleton-scale'")
    return scale


def _output_for(mesh_path: Path, output: str | None, fmt: str | None, preview: bool, *inputs: Path
                ) -> tuple[Path, str]:
    """The output path and format of a rig of ``mesh_path``; refused before any slow work if it would
    overwrite the mesh or another input, or cannot be written, or if ``preview`` lacks matplotlib."""
    from .exchange import default_output_path

    if output:
        for source in (mesh_path, *inputs):
            _refuse_input(Path(output), source)
    fmt = fmt or _format_of(output)
    out_path = Path(output) if output else default_output_path(mesh_path, fmt)
    _check_output(out_path, fmt)
    if preview:
        _require_matplotlib("--preview")
    return out_path, fmt


def _write(result, out_path: Path, fmt: str, mesh_path: Path, preview: bool, verbose: bool) -> Path | None:
    """Write the rig (and with ``preview`` its picture beside it, whose path is returned); with ``verbose``
    print every stage's time, these two included, on stderr."""
    from .exchange import write_rig

    start = time.perf_counter()
    write_rig(result, out_path, fmt, input_path=mesh_path)
    timings = {**result.timings, "write": time.perf_counter() - start}
    preview_path = None
    if preview:
        from .preview import render_preview
        start = time.perf_counter()
        preview_path = out_path.with_name((out_path.name if fmt == "pinocchio" else out_path.stem) + ".png")
        render_preview(result, preview_path, title=_preview_title(mesh_path.name, result))
        timings["preview"] = time.perf_counter() - start
    if verbose:
        width = max(map(len, timings))
        for stage, seconds in timings.items():
            click.echo(f"  {stage:<{width}}  {seconds:8.3f} s", err=True)
    return preview_path


def _named(result, names: str):
    """The rig with its joints named as ``--names`` says (``autorig.naming``)."""
    from .naming import rename_joints
    return rename_joints(result, names)


def _weakest(parts: dict[str, float]) -> str:
    """The lowest parts of a confidence, e.g. 'limbs 0.29, fit 0.41'."""
    low = sorted(parts.items(), key=lambda kv: kv[1])[:2]
    return ", ".join(f"{k} {v:.2f}" for k, v in low)


def _format_of(output: str | None) -> str:
    """The output format implied by ``-o``'s extension (glb without ``-o``)."""
    if output is None:
        return "glb"
    path = Path(output)
    if path.suffix.lower() in FORMAT_OF_SUFFIX:
        return FORMAT_OF_SUFFIX[path.suffix.lower()]
    if not path.suffix or path.is_dir():
        return "pinocchio"  # Pinocchio output is a folder holding skeleton.out and attachment.out
    raise click.UsageError(f"cannot tell the output format from {output!r}: use --format "
                           f"({', '.join(FORMATS)}) or an extension .glb, .gltf, .json, .usda, .usdc, .usdz or .fbx")


def _refuse_input(out: Path, mesh: Path) -> None:
    """Never write over the input: not the file itself under another spelling or a hard link, nor (for a
    Pinocchio folder) a folder that contains it. Checked before any slow work; ``write_rig`` checks again."""
    real_out, real_mesh = Path(os.path.realpath(out)), Path(os.path.realpath(mesh))
    if real_out == real_mesh or (out.exists() and os.path.samefile(out, mesh)) or real_out in real_mesh.parents:
        raise OutputError(f"cannot write {out}: it would overwrite the input {mesh}")


def _check_output(out: Path, fmt: str) -> None:
    """Refuse, before the slow work, outputs that ``write_rig`` would refuse after it: a missing or unwritable
    directory, or a directory where a file should go."""
    parent = out.parent
    if not parent.is_dir():
        what = "does not exist" if not parent.exists() else "is not a directory"
        raise OutputError(f"cannot write {out}: the directory {parent} {what}")
    if not os.access(parent, os.W_OK):
        raise OutputError(f"cannot write {out}: permission denied in {parent}")
    if fmt != "pinocchio" and out.is_dir():
        raise OutputError(f"cannot write {out}: it is a directory")
    if fmt in ("usda", "usdc", "usdz", "fbx"):
        # usd-core or Blender missing: say what to install before the slow work.
        from .exchange.fbx import blender_path
        from .exchange.usd import require_usd
        (blender_path if fmt == "fbx" else require_usd)()


def _require_matplotlib(what: str) -> None:
    """Fail at once, before any slow work, if the optional matplotlib (the ``preview`` extra) is missing."""
    import importlib.util

    if importlib.util.find_spec("matplotlib") is None:
        raise AutorigError(f"{what} needs matplotlib: pip install 'autorig[preview]'")


def _preview_title(name: str, rig) -> str:
    """The heading of a rig's picture: file name, template and counts."""
    return f"{name}: {rig.template or 'rig'}, {len(rig.names)} joints, {len(rig.vertices)} vertices"


def main(argv: list[str] | None = None) -> None:
    """Console entry point (``autorig = "autorig.cli:main"``)."""
    # autorig's dense linear algebra is tiny (3x3 frames, small fits): OpenBLAS's worker threads only spin
    # between calls, taking a core from libigl's parallel queries (20k-face rig, 9 runs: median 1.10 -> 1.04
    # s, CPU 1.43 -> 0.89 s). The process is autorig's, so one BLAS thread unless the user says otherwise;
    # it must be set before numpy loads.
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    cli.main(args=argv, prog_name="autorig")


if __name__ == "__main__":
    main()
