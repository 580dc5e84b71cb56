"""Errors that reach the user as one clear line (the CLI prints them without a traceback)."""


class UserError(Exception):
    """Bad input: a missing or corrupt file, an invalid value. The message names the bad value."""

    exit_code = 2


class ResourceError(UserError):
    """The machine, not the input, stopped the work (a full disk): one line naming the problem and what to do."""

    exit_code = 1
