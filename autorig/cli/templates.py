"""``autorig templates``: the built-in templates (``autorig.template``)."""
from __future__ import annotations

import click

from .common import AUTO_TEMPLATE, common_options


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
