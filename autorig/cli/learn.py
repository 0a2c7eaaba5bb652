"""``autorig learn``: a template learned from rigged characters (``autorig.learn``)."""
from __future__ import annotations

import time
from pathlib import Path

import click

from ..errors import OutputError
from .common import EXIT_CODES, common_options


@click.command("learn", epilog=EXIT_CODES, short_help="Learn a template from rigged characters.")
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
@common_options
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
    from ..exchange import write_file_atomic
    from ..learn import learn_template
    from ..template import base_description, load_template, template_json

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
