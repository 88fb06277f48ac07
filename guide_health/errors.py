"""Errors that the CLI turns into a one-line message and a non-zero exit."""


class InputError(ValueError):
    """Bad input from a user: a file, a parameter or a value that cannot be used."""
