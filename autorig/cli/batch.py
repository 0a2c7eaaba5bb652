"""``autorig batch``: every mesh in a folder (``autorig.batch.rig_folder``), with its progress on stderr."""
from __future__ import annotations

import click

from .common import (AXES, FINGERS_HELP, FORMATS, MAX_SEGMENTS_HELP, NAME_SCHEMES, NAMES_HELP, VOXELS_HELP,
                     common_options, exit_codes, input_options, parse_skeleton_scale)

# Must match autorig.batch.DEFAULT_EXTENSIONS (a test checks); repeated here so --help imports nothing.
BATCH_EXTENSIONS = "obj,off,ply,stl,glb,gltf"


@click.command("batch", epilog=exit_codes(1, 2, 3, 4, 7, 8, 9), short_help="Rig every mesh in a folder.")
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
@click.option("--convention", metavar="NAME",
              help="Put the joints where this convention's artists put them, for assets whose template has it "
                   "(see 'autorig conventions'). [default: each template's own]")
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
                   "ones first (one offline file; needs Pillow: pip install 'autorig[preview]'). Also: "
                   "html = \"PATH\" in INPUT_DIR's "
                   "autorig.toml, relative to OUTPUT_DIR.")
@click.option("--names", type=click.Choice(NAME_SCHEMES), default="template", show_default=True,
              help=NAMES_HELP)
@click.option("--fingers", is_flag=True, help=FINGERS_HELP)
@click.option("--fail-on-doubtful", is_flag=True,
              help="Exit with code 8 when no asset failed but some rig is doubtful (confidence below 0.5: "
                   "probably wrong); the JUnit report then fails those rigs too.")
@click.option("-q", "--quiet", is_flag=True, help="Print only failed and doubtful assets (and warnings).")
@input_options
@common_options
def batch_command(input_dir: str, output_dir: str, template: str, skeleton_file: str | None,
                  skeleton_scale: str | None, convention: str | None, up: str, front: str, voxels: int,
                  max_segments: int, fmt: str,
                  ext: str, jobs: int | None, scheduler: str | None, force: bool, report: str | None,
                  junit: str | None, html: str | None, names: str, fingers: bool, fail_on_doubtful: bool, quiet: bool,
                  max_faces: int,
                  allow_outside_paths: bool):
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
    the nearest file winning; template and skeleton replace each other (docs/tutorials/batch.md). A markers file
    beside an asset (hero.obj: hero.markers.json, as for autorig MESH --markers) rigs it around its markers: mark
    the wrong rigs and run the batch again. Assets unchanged since the last run (same content, markers, options
    and autorig version) are skipped unless --force. A failing
    asset does not stop the others: it is reported, and the exit code is 7. Progress goes to stderr (a bar
    on a terminal, else one line per asset); a summary line to stdout.
    """
    ctx = click.get_current_context()
    if jobs is not None and scheduler:
        raise click.UsageError("-j/--jobs does not apply with --scheduler: the cluster's workers decide")
    if skeleton_file is not None and ctx.get_parameter_source("template") == click.core.ParameterSource.COMMANDLINE:
        raise click.UsageError("--template and --skeleton are alternatives: give one (autorig.toml files may "
                               "still choose either per asset)")
    scale = parse_skeleton_scale(skeleton_scale)
    extensions = [e.strip().lstrip(".") for e in ext.split(",") if e.strip()]
    from ..input.mesh import FORMATS as MESH_FORMATS
    unknown = sorted({e for e in extensions if "." + e.lower() not in MESH_FORMATS})
    if unknown or not extensions:
        raise click.UsageError(f"--ext: autorig reads {', '.join(s[1:] for s in sorted(MESH_FORMATS))}"
                               + (f", not {', '.join(unknown)}" if unknown else ""))

    from ..batch import rig_folder
    from ..batch.progress import BatchProgress
    from ..pipeline import RigOptions, SkinOptions

    limits = {"max_faces": max_faces, "allow_outside_paths": allow_outside_paths}
    progress = BatchProgress(quiet=quiet)
    try:
        result = rig_folder(input_dir, output_dir, template,
                            RigOptions(up=up.lower(), front=front.lower(), voxels=voxels, max_segments=max_segments,
                                       convention=convention, fingers=fingers, **limits),
                            skeleton=skeleton_file, skin_options=SkinOptions(scale=scale, **limits), fmt=fmt,
                            extensions=extensions, jobs=jobs, scheduler=scheduler, force=force, report=report,
                            junit=junit, html=html, names=names, fail_on_doubtful=fail_on_doubtful,
                            on_start=progress.on_start,
                            on_result=progress.on_result)
    finally:
        progress.close()
    if not result.assets:
        click.echo(f"autorig: warning: no meshes in {input_dir}: looked for "
                   f"{', '.join('.' + e.lower() for e in extensions)} files (--ext), in every folder below it",
                   err=True)
    if not quiet:
        click.echo(batch_summary(result, output_dir))
    ctx.exit(result.exit_code)


def batch_summary(result, output_dir: str) -> str:
    """The batch's one summary line: "14 assets: 10 rigged, 1 failed, 3 unchanged (1 still failing); 2 rigs
    doubtful (probably wrong: look at them), 12.5 s -> rigged/". An unchanged rerun whose failures are
    unchanged says they are still failing, which is why its exit code stays 7."""
    counts = result.counts
    unchanged = f"{counts['skipped']} unchanged" + (f" ({counts['still_failing']} still failing)"
                                                     if counts["still_failing"] else "")
    doubtful = counts["doubtful"]
    doubts = (f"; {doubtful} rig{'s' * (doubtful != 1)} doubtful (probably wrong: look at "
              f"{'them' if doubtful != 1 else 'it'})" if doubtful else "")
    marked = sum(a.markers is not None for a in result.assets)
    doubts += f"; {marked} with markers" if marked else ""
    return (f"{len(result.assets)} assets: {counts['ok']} rigged, {counts['failed']} failed, {unchanged}{doubts}, "
            f"{result.seconds:.1f} s -> {output_dir}")
