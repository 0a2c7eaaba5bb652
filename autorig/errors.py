"""Errors a user can act on. The CLI prints ``str(error)`` as one line and exits with ``error.exit_code``.

``EXIT_CODES`` is the one table of autorig's exit codes: the README's table and every command's ``--help``
(each listing the codes it can return) are made from it or checked against it (tests/test_messages.py).
"""

EXIT_CODES = {
    0: "success",
    1: "general error (batch --scheduler: the Dask cluster cannot run the batch)",
    2: "bad input (mesh, rig, motion or map file), or a command-line usage error",
    3: "unknown or malformed template, or a bad --skeleton file",
    4: "output cannot be written",
    5: "the mesh was read but could not be rigged",
    6: "--strict: a doubtful result, nothing written (a rig's confidence below 0.5, or a motion that "
       "drives too few of its joints)",
    7: "batch: some assets could not be rigged (the others were; see the report)",
    8: "batch --fail-on-doubtful: none failed, but some rigs are probably wrong (confidence below 0.5)",
    9: "an optional package is missing: the message gives the pip install line",
    70: "internal error (a bug: run with --debug and report it)",
    130: "interrupted (Ctrl-C)",
}


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


class MissingPackageError(AutorigError):
    """An optional package a feature needs is not installed; the message ends with the ``pip install`` line."""
    exit_code = 9


def missing_package(what: str, package: str, extra: str) -> MissingPackageError:
    """"WHAT needs PACKAGE: pip install 'autorig[EXTRA]'", the one wording of a missing optional package."""
    return MissingPackageError(f"{what} needs {package}: pip install 'autorig[{extra}]'")


def printable(text: str) -> str:
    """``text`` with control characters, and the undecodable bytes of a file name (surrogates), written as
    escapes (``\\x1b``, ``\\udce9``): a name or message from a file reaches the terminal and reports as text,
    never as an escape sequence that clears the screen or moves the cursor."""
    import re
    return re.sub(r"[\x00-\x1f\x7f-\x9f\ud800-\udfff]",
                  lambda m: f"\\x{ord(m.group()):02x}" if ord(m.group()) < 0x100 else f"\\u{ord(m.group()):04x}",
                  text)
