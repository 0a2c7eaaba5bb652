"""autorig's version, in a module of its own: the modules that write it into their outputs (glTF's generator,
the batch's manifest and reports, ``--version``) import it from here, not from the package, whose ``__init__``
loads the pipeline that loads them."""
__version__ = "0.1.0"
