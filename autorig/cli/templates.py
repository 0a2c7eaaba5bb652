"""``autorig templates``: the built-in templates (``autorig.template``)."""
from __future__ import annotations

import click

from .common import AUTO_TEMPLATE, common_options, exit_codes


@click.command("templates", short_help="List the built-in templates.")
@common_options
def templates_command():
    """List the built-in templates: name, number of joints, description; and auto, the template-free skeleton."""
    from ..template import builtin_description, builtin_names, load_template

    for name in builtin_names():
        joints = len(load_template(name).names)
        click.echo(f"{name:<12} {joints:3d} joints  {builtin_description(name)}")
    click.echo(f"{AUTO_TEMPLATE:<12} any joints  No template: a skeleton made from the mesh's own shape, one chain per "
               f"limb, for any creature (Wade & Parent 2002; see --voxels, --max-segments).")


@click.command("conventions", epilog=exit_codes(3), short_help="List a template's conventions.")
@click.option("-t", "--template", default="biped", show_default=True, metavar="NAME|PATH",
              help="A built-in template name or a template .json file.")
@common_options
def conventions_command(template: str):
    """List where each source of a learned template's examples puts its joints (its conventions, for
    --convention): name, the sources it was learned from and how many examples; the default marked *."""
    from ..template import load_template

    loaded = load_template(template)
    if not loaded.conventions:
        click.echo(f"{loaded.name}: no conventions (not learned with them); the joints go where the template "
                   f"puts them")
        return
    for name, convention in loaded.conventions.items():
        mark = "*" if name == loaded.default_convention else " "
        sources = ", ".join(convention.get("sources", [])) or "-"
        click.echo(f"{mark} {name:<10} {convention.get('examples', 0):3d} examples  from {sources}"
                   + (f"  {convention['description']}" if convention.get("description") else ""))
