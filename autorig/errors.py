"""Errors a user can act on. The CLI prints ``str(error)`` as one line and exits with ``error.exit_code``."""


class AutorigError(Exception):
    """Base class: a problem with the user's input or environment, not a bug in autorig."""
    exit_code = 1


class InputError(AutorigError):
    """The input file is missing, unreadable, or not a usable mesh."""
    exit_code = 2


class TemplateError(AutorigError):
    """An unknown template name or a malformed template file."""
    exit_code = 3


class SkeletonError(TemplateError):
    """A ``--skeleton`` file that cannot be read or does not describe a joint tree (same exit code as a bad
    template: both are the skeleton the user supplied)."""


class OutputError(AutorigError):
    """The output path cannot be written."""
    exit_code = 4


class RigFailedError(AutorigError):
    """The mesh was read but no rig could be built for it (e.g. the template does not fit the shape)."""
    exit_code = 5


class LowConfidenceError(AutorigError):
    """--strict: a rig was made but its confidence is below the threshold, so it was not written."""
    exit_code = 6
