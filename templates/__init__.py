"""Built-in template skeletons, one JSON file each (read by ``autorig.template``)."""
