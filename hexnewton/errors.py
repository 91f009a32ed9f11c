"""The user-facing error type: command lines print its message as one line and exit non-zero (``cli.run``)."""


class HexnewtonError(RuntimeError):
    """A user-facing error: the CLI prints its message as one line and exits non-zero."""
