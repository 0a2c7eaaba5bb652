"""``autorig MESH`` (``autorig rig MESH``): rig a mesh with a template (``autorig.pipeline.rig``), or with
``--skeleton`` weigh the user's own skeleton (``autorig.pipeline.skin``), and write the result."""
from __future__ import annotations

import gc
import sys
import time
from pathlib import Path

import click

from ..quiet import quiet_libraries
from .common import (AUTO_TEMPLATE, AXES, FINGERS_HELP, FORMAT_OF_SUFFIX, FORMATS, MAX_SEGMENTS_HELP, NAME_SCHEMES,
                     NAMES_HELP, VOXELS_HELP, check_output, common_options, degrees, exit_codes, input_options,
                     joint_count, parse_skeleton_scale, preview_title, refuse_input, require_matplotlib, warn_dropped)


@click.command("rig", epilog=exit_codes(2, 3, 4, 5, 6, 9), short_help="Rig a mesh (the default command).")
@click.argument("mesh", metavar="MESH")
@click.option("-t", "--template", default="biped", show_default=True, metavar="NAME|PATH",
              help="Built-in template name (see 'autorig templates'), a template .json file, or auto: a "
                   "skeleton made from the mesh's own shape, for creatures no template fits.")
@click.option("-o", "--output", metavar="PATH",
              help="Where to write the rig. [default: beside MESH, e.g. hero.obj -> hero.rigged.glb]")
@click.option("-f", "--format", "fmt", type=click.Choice(FORMATS),
              help="Output format. [default: from -o's extension (.glb, .gltf, .json, .usda/.usdc/.usdz, "
                   ".fbx; no extension: pinocchio folder), else glb]")
@click.option("--convention", metavar="NAME",
              help="Put the joints where this convention's artists put them (see 'autorig conventions'). "
                   "[default: the template's, for the built-in biped the engines' humanoid: hip joints at the "
                   "femoral heads, as Mixamo, Unity, Unreal and the glTF samples expect]")
@click.option("--up", type=click.Choice(AXES, case_sensitive=False), default="auto", show_default=True,
              help="The mesh's up axis, or auto to detect it.")
@click.option("--front", type=click.Choice(AXES, case_sensitive=False), default="auto", show_default=True,
              help="The axis the character faces, or auto to detect it (glTF's +z unless the shape "
                   "clearly says otherwise).")
@click.option("--markers", "markers_file", metavar="FILE",
              help="A JSON object of marker names to [x, y, z] points in the mesh's own coordinates: the joints "
                   "they name are put there and the rest follows. Biped, humanoid: chin, left_wrist, right_wrist, "
                   "left_elbow, right_elbow, left_knee, right_knee, groin; quadruped, horse: front_left_paw, "
                   "front_right_paw, back_left_paw, back_right_paw, head, tail_base, withers; any joint name "
                   "of the template too.")
@click.option("--strict", is_flag=True,
              help="Write nothing and exit with code 6 when the rig's confidence is below 0.5 (probably wrong); "
                   "not with --template auto, which has no confidence.")
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
@click.option("--fingers", is_flag=True, help=FINGERS_HELP)
@click.option("-v", "--verbose", is_flag=True, help="Also print each stage's time (on stderr).")
@click.option("-q", "--quiet", is_flag=True,
              help="Print nothing on success (warnings still, and a doubtful rig's confidence as one).")
@input_options
@common_options
def rig_command(mesh: str, template: str, output: str | None, fmt: str | None, convention: str | None, up: str,
                front: str, markers_file: str | None,
                strict: bool, preview: bool, voxels: int, max_segments: int, skeleton_file: str | None,
                skeleton_scale: str | None, names: str, fingers: bool, verbose: bool, quiet: bool, max_faces: int,
                allow_outside_paths: bool):
    """Rig MESH (OBJ, PLY, STL, OFF, glTF/GLB) with a template skeleton and write the result; or, with
    --skeleton, compute skin weights for your own skeleton.

    On success prints one line: the mesh, template, joint and vertex counts, time and output path.

    To fix a wrong rig: look at it (autorig preview, or the batch's review page), write where its joints
    should be into a markers file, e.g. hero.markers.json: {"left_wrist": [0.71, 1.02, -0.02], "chin": [0,
    1.52, 0.09]} (the mesh's own coordinates), and rig again with --markers hero.markers.json.
    """
    if verbose and quiet:
        raise click.UsageError("--verbose and --quiet cannot be used together")
    start = time.perf_counter()
    from ..input.mesh import check_mesh_path, frame_rotation
    from ..template import load_template

    if skeleton_file is not None or skeleton_scale is not None:
        if markers_file is not None:
            raise click.UsageError("--markers place a template's joints; --skeleton keeps your own joints where "
                                   "they are")
        if fingers:
            raise click.UsageError("--fingers adds finger joints to a template's rig; --skeleton keeps your own "
                                   "joints (give it finger joints instead)")
        return _skin_command(mesh, skeleton_file, skeleton_scale, output, fmt, preview, names, verbose, quiet,
                             start, {"max_faces": max_faces, "allow_outside_paths": allow_outside_paths})
    mesh_path = check_mesh_path(mesh)
    skeleton = template if template == AUTO_TEMPLATE else load_template(template)
    if skeleton != AUTO_TEMPLATE:
        from ..embed.convention import convention_named
        convention_named(skeleton, convention)   # an unknown convention fails here, before any slow work
    elif convention is not None:
        raise click.UsageError("--convention needs a learned template: --template auto has no conventions")
    if markers_file is not None:
        if skeleton == AUTO_TEMPLATE:
            raise click.UsageError("--markers need a template: --template auto makes its own skeleton")
        from ..markers import read_markers
        read_markers(markers_file, skeleton)   # a bad markers file fails here, before any slow work
    if fingers and skeleton == AUTO_TEMPLATE:
        raise click.UsageError("--fingers needs a template with hands: --template auto finds no wrists")
    if names != "template":
        from ..naming import check_names
        # A template without Mixamo names fails here, before any slow work.
        check_names(["root"] if skeleton == AUTO_TEMPLATE else list(skeleton.names), names)
    if "auto" not in (up, front):
        frame_rotation(up, front)  # rejects up parallel to front before any slow work
    out_path, fmt = _output_for(mesh_path, output, fmt, preview)

    from ..confidence import STRICT_THRESHOLD
    from ..errors import LowConfidenceError
    from ..explain import confidence_words, is_doubtful
    from ..pipeline import RigOptions, rig
    with quiet_libraries(shown=verbose):
        _import_paused(RIG_MODULES, fmt)
        result = rig(str(mesh_path), skeleton, RigOptions(up=up, front=front, voxels=voxels, max_segments=max_segments,
                                                          convention=convention, max_faces=max_faces,
                                                          allow_outside_paths=allow_outside_paths,
                                                          fingers=fingers, markers=markers_file))
        warn_dropped(mesh, result.info)
        confidence = result.info["confidence"]
        if strict and confidence is not None and confidence < STRICT_THRESHOLD:
            reasons = "; ".join(result.info.get("confidence_reasons") or ["no one part stands out"])
            raise LowConfidenceError(f"{mesh}: confidence {confidence:.2f} is below {STRICT_THRESHOLD}, probably "
                                     f"wrong ({reasons}); nothing written")
        preview_path = _write(_named(result, names), out_path, fmt, mesh_path, preview, verbose)
    end = time.perf_counter()

    if quiet and is_doubtful(confidence):     # a warning: said even when quiet
        click.echo(f"autorig: warning: {mesh}: {confidence_words(confidence, result.info['confidence_reasons'])}",
                   err=True)
    if not quiet:
        axes = f"up {result.info['up']}, front {result.info['front']}"
        if result.info["axes_detected"]:
            axes += " (from the markers)" if len(result.info.get("axes_from_markers", ())) == sum(
                a == "auto" for a in (up, front)) else " (detected)"
        if "markers" in result.info:
            axes += f", {len(result.info['markers'])} markers held"
        if "rest_pose" in result.info:    # autorig.readoff.rest_pose: the arms' pose the bind pose is in
            axes += f", {result.info['rest_pose']} ({degrees(result.info['arm_angle'])})"
        template_name = result.template + (f" ({result.info['convention']})" if "convention" in result.info else "")
        words = confidence_words(confidence, result.info.get("confidence_reasons") or [])
        click.echo(f"{mesh}: {template_name}, {joint_count(result)}, {len(result.vertices)} input vertices, "
                   f"{axes}, {words}{_hands(result.info)}, {end - start:.2f} s -> {out_path}"
                   + (f" (preview {preview_path})" if preview else ""))


def _hands(info: dict) -> str:
    """", hands: left fingers, right mitten" for a rig whose hands were read (``autorig.hands``), else ""."""
    hands = info.get("hands")
    return ", hands: " + ", ".join(f"{side} {status}" for side, status in hands.items()) if hands else ""


# What each command's pipeline imports (see _import_paused); a module missing here only costs some speed.
RIG_MODULES = ("autorig.pipeline", "autorig.weights.attach", "igl", "scipy.sparse.linalg", "scipy.optimize")


SKIN_MODULES = ("autorig.pipeline", "autorig.weights.attach", "autorig.weights.bones", "igl", "scipy.sparse.linalg")


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
                  fmt: str | None, preview: bool, names: str, verbose: bool, quiet: bool, start: float,
                  limits: dict) -> None:
    """``autorig MESH --skeleton FILE``: weights for the user's skeleton (``autorig.pipeline.skin``);
    ``limits``: the ``SkinOptions``' max_faces and allow_outside_paths."""
    ctx = click.get_current_context()
    if skeleton_file is None:
        raise click.UsageError("--skeleton-scale applies to --skeleton")
    # Options of the embedding mean nothing here; given explicitly, they are a mistake worth saying.
    for param in ("template", "up", "front", "strict", "voxels", "max_segments"):
        if ctx.get_parameter_source(param) == click.core.ParameterSource.COMMANDLINE:
            raise click.UsageError(f"--{param.replace('_', '-')} does not apply with --skeleton (the skeleton is "
                                   f"given, not embedded)")
    scale = parse_skeleton_scale(skeleton_scale)

    from ..exchange.skeleton import read_skeleton
    from ..input.mesh import check_mesh_path

    mesh_path = check_mesh_path(mesh)
    out_path, fmt = _output_for(mesh_path, output, fmt, preview, Path(skeleton_file))
    with quiet_libraries(shown=verbose):
        skeleton = read_skeleton(skeleton_file)
    if fmt == "pinocchio":
        from ..exchange.pinocchio import unfit_skeleton
        problem = unfit_skeleton(skeleton.parents)
        if problem:
            raise click.UsageError(f"--format pinocchio: {skeleton_file}: {problem}")

    from ..pipeline import SkinOptions, skin
    with quiet_libraries(shown=verbose):
        _import_paused(SKIN_MODULES, fmt)
        result = skin(str(mesh_path), skeleton, SkinOptions(scale=scale, **limits))
        warn_dropped(mesh, result.info)
        preview_path = _write(_named(result, names), out_path, fmt, mesh_path, preview, verbose)
    end = time.perf_counter()

    if not quiet:
        info = result.info
        cold = sum(map(len, info["cold_bones"].values()))
        click.echo(f"{mesh}: skeleton {skeleton_file}, {len(result.names)} joints ({info['joints_weighted']} "
                   f"weighted, {len(info['tip_bones'])} tip bones, {cold} bones left cold), {len(result.vertices)} "
                   f"input vertices, {end - start:.2f} s -> {out_path}" + (f" (preview {preview_path})" if preview else ""))


def _output_for(mesh_path: Path, output: str | None, fmt: str | None, preview: bool, *inputs: Path
                ) -> tuple[Path, str]:
    """The output path and format of a rig of ``mesh_path``; refused before any slow work if it would
    overwrite the mesh or another input, or cannot be written, or if ``preview`` lacks matplotlib."""
    from ..exchange import default_output_path

    if output:
        for source in (mesh_path, *inputs):
            refuse_input(Path(output), source)
    fmt = fmt or _format_of(output)
    out_path = Path(output) if output else default_output_path(mesh_path, fmt)
    check_output(out_path, fmt)
    if preview:
        require_matplotlib("--preview")
    return out_path, fmt


def _write(result, out_path: Path, fmt: str, mesh_path: Path, preview: bool, verbose: bool) -> Path | None:
    """Write the rig (and with ``preview`` its picture beside it, whose path is returned); with ``verbose``
    print every stage's time, these two included, on stderr."""
    from ..exchange import write_rig

    start = time.perf_counter()
    write_rig(result, out_path, fmt, input_path=mesh_path)
    timings = {**result.timings, "write": time.perf_counter() - start}
    preview_path = None
    if preview:
        from ..show.preview import render_preview
        start = time.perf_counter()
        preview_path = out_path.with_name((out_path.name if fmt == "pinocchio" else out_path.stem) + ".png")
        render_preview(result, preview_path, title=preview_title(mesh_path.name, result))
        timings["preview"] = time.perf_counter() - start
    if verbose:
        width = max(map(len, timings))
        for stage, seconds in timings.items():
            click.echo(f"  {stage:<{width}}  {seconds:8.3f} s", err=True)
    return preview_path


def _named(result, names: str):
    """The rig with its joints named as ``--names`` says (``autorig.naming``)."""
    from ..naming import rename_joints
    return rename_joints(result, names)


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
