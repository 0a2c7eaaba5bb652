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


def printable(text: str) -> str:
    """``text`` with control characters, and the undecodable bytes of a file name (surrogates), written as
    escapes (``\\x1b``, ``\\udce9``): a name or message from a file reaches the terminal and reports as text,
    never as an escape sequence that clears the screen or moves the cursor."""
    import re
    return re.sub(r"[\x00-\x1f\x7f-\x9f\ud800-\udfff]",
                  lambda m: f"\\x{ord(m.group()):02x}" if ord(m.group()) < 0x100 else f"\\u{ord(m.group()):04x}",
                  text)
