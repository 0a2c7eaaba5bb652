"""The ``autorig`` command line.

    autorig hero.obj                        # rig with the biped template -> hero.rigged.glb
    autorig hero.obj --template quadruped -o out/hero.json
    autorig hero.obj --skeleton my_rig.glb  # weights only, for your own skeleton (.json, .glb/.gltf, .bvh)
    autorig rig hero.obj ...                # the same: ``rig`` is the default command
    autorig templates                       # list the built-in templates
    autorig conventions                     # where each source of the biped's examples puts its joints
    autorig batch assets/ -o rigged/        # every mesh in a folder (autorig.batch)
    autorig hero.obj --preview              # also hero.rigged.png: front and side views (autorig.show.preview)
    autorig preview hero.rigged.glb         # the same picture of an existing rig
    autorig pose hero.rigged.glb -m walk.bvh -o walk.glb    # retarget a BVH motion (autorig.show.pose)
    autorig learn rigs/*.glb -o studio.json                 # a template learned from rigged characters

One module per command, each a thin layer over the library: ``rig`` (the default command), ``batch``,
``learn``, ``pose``, ``preview`` and ``templates`` (with ``conventions``); what they share (the group that turns errors into exit codes,
the common options and output checks) is in ``common``.

Start-up must stay fast (``autorig --help`` well under 0.3 s): at module level import only click, the standard
library and ``autorig``'s own light modules; numpy, trimesh, libigl and the pipeline load inside the commands.
"""
from __future__ import annotations

import os

import click

from .batch import BATCH_EXTENSIONS, batch_command
from .common import AUTO_TEMPLATE, EXIT_CODES, FORMATS, DefaultCommandGroup, version_option
from .learn import learn_command
from .pose import pose_command
from .preview import preview_command
from .rig import rig_command
from .templates import conventions_command, templates_command

__all__ = ["cli", "main", "FORMATS", "AUTO_TEMPLATE", "BATCH_EXTENSIONS"]


@click.group(cls=DefaultCommandGroup, default_command="rig", epilog=EXIT_CODES,
             context_settings={"help_option_names": ["-h", "--help"]})
@version_option
def cli():
    """Rig 3D characters automatically: embed a template skeleton in a mesh and compute skin weights.

    \b
      autorig MESH [OPTIONS]    rig a mesh; short for 'autorig rig MESH [OPTIONS]'
                                (see 'autorig rig --help' for the options)
      autorig templates         list the built-in templates
      autorig conventions       list the biped's conventions (for --convention)
      autorig batch DIR -o OUT  rig every mesh in a folder (see 'autorig batch --help')
      autorig preview RIG       draw a rig file to a PNG
      autorig pose RIG -m BVH   move a rig file with a BVH motion
      autorig learn RIGS -o T   learn a template from rigged characters
    """


cli.add_command(rig_command)
cli.add_command(templates_command)
cli.add_command(conventions_command)
cli.add_command(batch_command)
cli.add_command(preview_command)
cli.add_command(pose_command)
cli.add_command(learn_command)


def main(argv: list[str] | None = None) -> None:
    """Console entry point (``autorig = "autorig.cli:main"``)."""
    # autorig's dense linear algebra is tiny (3x3 frames, small fits): OpenBLAS's worker threads only spin
    # between calls, taking a core from libigl's parallel queries (20k-face rig, 9 runs: median 1.10 -> 1.04
    # s, CPU 1.43 -> 0.89 s). The process is autorig's, so one BLAS thread unless the user says otherwise;
    # it must be set before numpy loads.
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    cli.main(args=argv, prog_name="autorig")
