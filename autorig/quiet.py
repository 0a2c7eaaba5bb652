"""Keep other libraries' warnings and log lines off the user's terminal."""
from __future__ import annotations

import contextlib


@contextlib.contextmanager
def quiet_libraries(shown: bool = False):
    """Hide the warnings and log messages of numpy, trimesh and friends unless ``shown``: on a normal run
    stderr carries only autorig's own lines. Restores the previous settings afterwards."""
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
