"""What the commands share: the group that turns errors into exit codes, the common options, the axes and
formats the options offer, and the checks that refuse an output before any slow work.

Start-up must stay fast (``autorig --help`` well under 0.3 s): at module level only click, the standard library
and ``autorig``'s own light modules.
"""
from __future__ import annotations

import os
import traceback
from pathlib import Path

import click

from ..errors import EXIT_CODES as ALL_EXIT_CODES
from ..errors import AutorigError, OutputError, missing_package, printable
from ..version import __version__

AXES = ["auto", "x", "y", "z", "-x", "-y", "-z", "+x", "+y", "+z"]


# Must match autorig.exchange.FORMATS (a test checks); repeated here so --help need not import numpy.
FORMATS = ["glb", "gltf", "pinocchio", "json", "usda", "usdc", "usdz", "fbx"]


# Must match autorig.extract.AUTO (a test checks): the template name of template-free skeletons.
AUTO_TEMPLATE = "auto"


FORMAT_OF_SUFFIX = {".glb": "glb", ".gltf": "gltf", ".json": "json", ".usda": "usda", ".usdc": "usdc",
                    ".usdz": "usdz", ".fbx": "fbx"}


EXIT_INTERNAL = 70   # EX_SOFTWARE from BSD sysexits: a bug in autorig


EXIT_INTERRUPTED = 130  # 128 + SIGINT, what shells report for Ctrl-C


def exit_codes(*codes: int) -> str:
    """The "Exit codes:" epilog of a command that can return ``codes`` (from ``autorig.errors.EXIT_CODES``;
    0, 70 and 130 are always listed)."""
    shown = sorted({0, *codes, EXIT_INTERNAL, EXIT_INTERRUPTED})
    return "\b\nExit codes:\n" + "\n".join(f"  {code:<4} {ALL_EXIT_CODES[code]}" for code in shown)


EXIT_CODES = exit_codes(*ALL_EXIT_CODES)   # the group's --help: every code


_DEBUG = "autorig.debug"  # key in click's ctx.meta, which a group shares with its subcommands


# Shared by 'autorig rig' and 'autorig batch'. NAME_SCHEMES must match autorig.naming.NAME_SCHEMES.
NAME_SCHEMES = ["template", "mixamo", "unity", "unreal"]


NAMES_HELP = ("Joint names in the output: the template's, mixamo (mixamorig:Hips, mixamorig:LeftUpLeg, ...) for "
              "animation libraries, unity (Hips, LeftUpperArm, ...: a Humanoid avatar's bones) or unreal (pelvis, "
              "spine_01, clavicle_l, upperarm_l, ...: the UE mannequin's); biped and humanoid only.")


FINGERS_HELP = ("Also read five fingers of three joints off each hand (autorig.hands), whatever the template; a hand "
                "that shows no fingers (a mitten, a fist) gets none, and the summary says so.")


VOXELS_HELP = "--template auto: voxels along the mesh's longest side (finer finds thinner limbs)."


MAX_SEGMENTS_HELP = "--template auto: the most bones per chain (limb), plus one for each chain hanging from it."


# Axes of an existing rig file: the file does not record them, so no detection.
RIG_AXES = [axis for axis in AXES if axis != "auto"]


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
    click.echo(printable(" ".join(message.split("\n"))), err=True)


def _set_debug(ctx: click.Context, _param, value: bool) -> None:
    if value:
        ctx.meta[_DEBUG] = True


version_option = click.version_option(__version__, "--version", prog_name="autorig", message="%(prog)s %(version)s")


def common_options(command):
    command = click.option("--debug", is_flag=True, expose_value=False, is_eager=True, callback=_set_debug,
                           help="Show the full traceback of an error.")(command)
    return version_option(command)


MAX_FACES_HELP = ("Refuse (exit 2) a mesh of more triangles than this, before reading it; also refused: one too big "
                  "for the memory available. [default: 5000000]")


ALLOW_OUTSIDE_HELP = ("Let a mesh read textures, MTL files and buffers it names outside its own folder (absolute "
                      "paths, '..', symlinks leading out, file: URIs). Off by default: such paths are refused with "
                      "a warning and the rig is made without them.")


def input_options(command):
    """--max-faces and --allow-outside-paths, shared by 'autorig rig' and 'autorig batch'. The default must match
    autorig.input.limits.MAX_FACES (a test checks); repeated so that --help need not import numpy."""
    command = click.option("--allow-outside-paths", is_flag=True, help=ALLOW_OUTSIDE_HELP)(command)
    return click.option("--max-faces", type=click.IntRange(min=1), default=5_000_000, metavar="N",
                        help=MAX_FACES_HELP)(command)


def warn_dropped(source: str, info: dict) -> None:
    """One warning line on stderr for each part of the look a rig left out (``rig.info["dropped"]``)."""
    from ..input.confine import dropped_line
    for dropped in info.get("dropped", []):
        _error_line(f"autorig: warning: {dropped_line(source, dropped)}")


def parse_skeleton_scale(text: str | None) -> float | str | None:
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


def refuse_input(out: Path, mesh: Path) -> None:
    """Never write over the input: not the file itself under another spelling or a hard link, nor (for a
    Pinocchio folder) a folder that contains it. Checked before any slow work; ``write_rig`` checks again."""
    real_out, real_mesh = Path(os.path.realpath(out)), Path(os.path.realpath(mesh))
    if real_out == real_mesh or (out.exists() and os.path.samefile(out, mesh)) or real_out in real_mesh.parents:
        raise OutputError(f"cannot write {out}: it would overwrite the input {mesh}")


def check_output(out: Path, fmt: str) -> None:
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
        from ..exchange.fbx import blender_path
        from ..exchange.usd import require_usd
        (blender_path if fmt == "fbx" else require_usd)()


def require_matplotlib(what: str) -> None:
    """Fail at once, before any slow work, if the optional matplotlib (the ``preview`` extra) is missing."""
    import importlib.util

    if importlib.util.find_spec("matplotlib") is None:
        raise missing_package(what, "matplotlib", "preview")


def degrees(angle: float) -> str:
    """An angle in whole degrees, never "-0 deg": "41 deg"."""
    return f"{round(float(angle)) + 0:d} deg"


def joint_count(rig) -> str:
    """"24 joints (19 + 5 tips)": a rig's joints, with the tips (joints with no child: where a chain ends,
    autorig's *_end, no bone and no weight of their own) counted apart; "3 joints" when none is a tip."""
    names, parents = list(rig.names), {int(p) for p in rig.parents}
    tips = sum(j not in parents for j in range(len(names)))
    return f"{len(names)} joints" + (f" ({len(names) - tips} + {tips} tips)" if tips and len(names) > 1 else "")


def preview_title(name: str, rig, vertices: str = "input vertices") -> str:
    """The heading of a rig's picture: file name, template and counts. ``vertices`` names which: a rig just
    made has the input mesh's ("input vertices"); a rig file has its own, a glTF's split where UVs or normals
    differ ("vertices in the file")."""
    return f"{name}: {rig.template or 'rig'}, {joint_count(rig)}, {len(rig.vertices)} {vertices}"


def rig_axes(rig, up: str | None, front: str | None) -> tuple[str, str]:
    """(up, front) of a rig read from a file: the ones given, else the ones autorig recorded in it
    (``exchange.gltf.recorded_axes``), else glTF's y and z; raises ``AxisError`` when they are parallel."""
    from ..input.mesh import frame_rotation
    up, front = up or rig.info.get("up") or "y", front or rig.info.get("front") or "z"
    frame_rotation(up, front)
    return up, front
