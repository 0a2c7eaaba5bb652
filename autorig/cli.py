"""The ``autorig`` command line.

    autorig hero.obj                        # rig with the biped template -> hero.rigged.glb
    autorig hero.obj --template quadruped -o out/hero.json
    autorig rig hero.obj ...                # the same: ``rig`` is the default command
    autorig templates                       # list the built-in templates

Start-up must stay fast (``autorig --help`` well under 0.3 s): at module level import only click, the standard
library and ``autorig``'s own light modules; numpy, trimesh, libigl and the pipeline load inside the commands.
"""
from __future__ import annotations

import contextlib
import os
import time
import traceback
from pathlib import Path

import click

from . import __version__
from .errors import AutorigError, OutputError

AXES = ["auto", "x", "y", "z", "-x", "-y", "-z", "+x", "+y", "+z"]
# Must match autorig.exchange.FORMATS (a test checks); repeated here so --help need not import numpy.
FORMATS = ["glb", "gltf", "pinocchio", "json"]
FORMAT_OF_SUFFIX = {".glb": "glb", ".gltf": "gltf", ".json": "json"}

EXIT_INTERNAL = 70   # EX_SOFTWARE from BSD sysexits: a bug in autorig
EXIT_INTERRUPTED = 130  # 128 + SIGINT, what shells report for Ctrl-C

EXIT_CODES = """\b
Exit codes:
  0    success
  1    general error
  2    bad input mesh, or a command-line usage error
  3    unknown or malformed template
  4    output cannot be written
  5    the mesh was read but could not be rigged
  6    --strict: the rig's confidence is below the threshold (nothing written)
  70   internal error (a bug: run with --debug and report it)
  130  interrupted (Ctrl-C)"""

_DEBUG = "autorig.debug"  # key in click's ctx.meta, which a group shares with its subcommands


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
    """


@cli.command("rig", epilog=EXIT_CODES, short_help="Rig a mesh (the default command).")
@click.argument("mesh", metavar="MESH")
@click.option("-t", "--template", default="biped", show_default=True, metavar="NAME|PATH",
              help="Built-in template name (see 'autorig templates') or a template .json file.")
@click.option("-o", "--output", metavar="PATH",
              help="Where to write the rig. [default: beside MESH, e.g. hero.obj -> hero.rigged.glb]")
@click.option("-f", "--format", "fmt", type=click.Choice(FORMATS),
              help="Output format. [default: from -o's extension (.glb, .gltf, .json; no extension: "
                   "pinocchio folder), else glb]")
@click.option("--up", type=click.Choice(AXES, case_sensitive=False), default="auto", show_default=True,
              help="The mesh's up axis, or auto to detect it.")
@click.option("--front", type=click.Choice(AXES, case_sensitive=False), default="auto", show_default=True,
              help="The axis the character faces, or auto to detect it (glTF's +z unless the shape "
                   "clearly says otherwise).")
@click.option("--strict", is_flag=True,
              help="Write nothing and exit with code 6 when the rig's confidence is below the threshold.")
@click.option("-v", "--verbose", is_flag=True, help="Also print each stage's time (on stderr).")
@click.option("-q", "--quiet", is_flag=True, help="Print nothing on success.")
@_common_options
def rig_command(mesh: str, template: str, output: str | None, fmt: str | None, up: str, front: str,
                strict: bool, verbose: bool, quiet: bool):
    """Rig MESH (OBJ, PLY, STL, OFF, glTF/GLB) with a template skeleton and write the result.

    On success prints one line: the mesh, template, joint and vertex counts, time and output path.
    """
    if verbose and quiet:
        raise click.UsageError("--verbose and --quiet cannot be used together")
    start = time.perf_counter()
    from .exchange import default_output_path, write_rig
    from .mesh import check_mesh_path, frame_rotation
    from .template import load_template

    mesh_path = check_mesh_path(mesh)
    skeleton = load_template(template)
    if "auto" not in (up, front):
        frame_rotation(up, front)  # rejects up parallel to front before any slow work
    if output:
        _refuse_input(Path(output), mesh_path)
    fmt = fmt or _format_of(output)
    out_path = Path(output) if output else default_output_path(mesh_path, fmt)
    _check_output(out_path, fmt)

    from .confidence import STRICT_THRESHOLD
    from .errors import LowConfidenceError
    from .pipeline import RigOptions, rig
    with _library_noise(shown=verbose):
        result = rig(str(mesh_path), skeleton, RigOptions(up=up, front=front))
        confidence = result.info["confidence"]
        if strict and confidence < STRICT_THRESHOLD:
            raise LowConfidenceError(f"{mesh}: confidence {confidence:.2f} is below {STRICT_THRESHOLD} "
                                     f"({_weakest(result.info['confidence_parts'])}); nothing written")
        write_start = time.perf_counter()
        write_rig(result, out_path, fmt, input_path=mesh_path)
    end = time.perf_counter()

    if verbose:
        timings = {**result.timings, "write": end - write_start}
        width = max(map(len, timings))
        for stage, seconds in timings.items():
            click.echo(f"  {stage:<{width}}  {seconds:8.3f} s", err=True)
    if not quiet:
        axes = f"up {result.info['up']}, front {result.info['front']}"
        if result.info["axes_detected"]:
            axes += " (detected)"
        click.echo(f"{mesh}: {result.template}, {len(result.names)} joints, {len(result.vertices)} vertices, "
                   f"{axes}, confidence {result.info['confidence']:.2f}, {end - start:.2f} s -> {out_path}")


@cli.command("templates", short_help="List the built-in templates.")
@_common_options
def templates_command():
    """List the built-in templates: name, number of joints, description."""
    import json
    from importlib import resources

    from .template import builtin_names, load_template

    for name in builtin_names():
        joints = len(load_template(name).names)
        data = json.loads(resources.files("autorig.templates").joinpath(name + ".json").read_text())
        click.echo(f"{name:<12} {joints:3d} joints  {data.get('description', '')}")


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
                           f"({', '.join(FORMATS)}) or an extension .glb, .gltf or .json")


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


@contextlib.contextmanager
def _library_noise(shown: bool):
    """Hide the warnings and log messages of numpy, trimesh and friends unless ``shown``: on a normal run
    stderr carries only autorig's own error line. Restores the previous settings afterwards."""
    if shown:
        yield
        return
    import logging
    import warnings

    previous = logging.root.manager.disable
    logging.disable(logging.CRITICAL)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            yield
    finally:
        logging.disable(previous)


def main(argv: list[str] | None = None) -> None:
    """Console entry point (``autorig = "autorig.cli:main"``)."""
    cli.main(args=argv, prog_name="autorig")


if __name__ == "__main__":
    main()
