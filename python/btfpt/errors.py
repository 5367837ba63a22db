"""The exceptions btfpt raises. Every one is a :class:`btfpt.Error` and carries the message the
`btfpt` command line prints for the same problem; each also derives from the matching built-in
exception, so ``except FileNotFoundError`` or ``except ValueError`` work as expected."""


class Error(Exception):
    """Base class of every btfpt error."""


class MissingFileError(Error, FileNotFoundError):
    """A named file or folder does not exist."""


class FormatError(Error, ValueError):
    """A file is malformed, truncated, corrupt or of an unsupported kind."""


class SceneError(FormatError):
    """A problem in a scene description (the message names file and line)."""


class InvalidArgumentError(Error, ValueError):
    """An argument or setting is invalid (the message names it)."""


class IoError(Error, OSError):
    """An operating-system I/O failure on a named file."""


class InterruptedError_(Error):
    """Work stopped on request; the message says what was kept and how to continue."""


Interrupted = InterruptedError_

__all__ = [
    "Error",
    "MissingFileError",
    "FormatError",
    "SceneError",
    "InvalidArgumentError",
    "IoError",
    "Interrupted",
]
