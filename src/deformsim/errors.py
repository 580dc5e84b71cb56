"""Errors that reach the user as one clear line (the CLI prints them without a traceback)."""


class UserError(Exception):
    """Bad input: a missing or corrupt file, an invalid value. The message names the bad value."""
