"""``python -m autorig.cli``: the command line, as the ``autorig`` script runs it."""
from . import main

main()
