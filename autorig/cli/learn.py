"""``autorig learn``: a template learned from rigged characters (``autorig.learn``)."""
from __future__ import annotations

import time
from pathlib import Path

import click

from ..errors import OutputError
from .common import common_options, exit_codes


@click.command("learn", epilog=exit_codes(2, 3, 4, 5),
               short_help="Learn a template from rigged characters.")
@click.argument("rigs", nargs=-1, required=True, metavar="RIGS...")
@click.option("-o", "--output", required=True, metavar="TEMPLATE.json", help="Where to write the template.")
@click.option("-t", "--template", "base", metavar="NAME|PATH",
              help="The template whose joint names corpus folders map to (their joints.json maps); without it "
                   "the rigged glTF files' own joints and hierarchy are learned.")
@click.option("--name", metavar="NAME", help="The learned template's name. [default: the base's, or the file's stem]")
@click.option("--learn", "parts", default="proportions,penalties,placement,confidence", show_default=True,
              metavar="PARTS", help="What to learn (comma-separated, of proportions, penalties, orientation, "
                                    "placement, conventions, legs, confidence); with --template the rest is the "
                                    "base's. orientation: how much detection weighs the head/tail cues, the feet's "
                                    "among them (four-legged templates); legs: where leg joints sit on the legs the "
                                    "mesh shows (four-legged templates); conventions: where each source's artists "
                                    "put the joints, "
                                    "apart from the shared anatomy (needs placement).")
@click.option("--convention", "conventions", multiple=True, metavar="NAME=SOURCE[,SOURCE...]",
              help="With --learn conventions: ship the convention NAME, the mean of these sources' own (a "
                   "source is a corpus folder's source_group, else its name's prefix, e.g. 0ad, else its "
                   "folder's name). Sources no NAME covers ship under their own name. Repeatable.")
@click.option("--default-convention", metavar="NAME",
              help="The convention rigs take unless told. [default: the one most examples follow]")
@click.option("-q", "--quiet", is_flag=True, help="Print nothing on success.")
@common_options
def learn_command(rigs: tuple[str, ...], output: str, base: str | None, name: str | None, parts: str,
                  conventions: tuple[str, ...], default_convention: str | None, quiet: bool):
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
                             progress=progress, parts=[p.strip() for p in parts.split(",") if p.strip()],
                             conventions=_named_conventions(conventions), default=default_convention)
    description = (base_description(base) + " " if base else "") + \
        f"Learned by autorig learn from {len(learned.examples)} rigged characters."
    write_file_atomic(out, template_json(learned.template.to_dict(description)).encode())
    if not quiet:
        t = learned.template
        click.echo(f"{t.name}: {len(t.names)} joints, {len(t.helpers)} helpers, from {len(learned.examples)} "
                   f"examples in {time.perf_counter() - start:.1f} s -> {out}")


def _named_conventions(given: tuple[str, ...]) -> dict[str, list[str]] | None:
    """{name: [sources]} of the ``--convention NAME=SOURCE,...`` options, or None for none."""
    out = {}
    for item in given:
        name, _, sources = item.partition("=")
        members = [s.strip() for s in sources.split(",") if s.strip()]
        if not name.strip() or not members:
            raise click.UsageError(f"--convention {item!r}: expected NAME=SOURCE[,SOURCE...]")
        out[name.strip()] = members
    return out or None
