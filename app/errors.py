"""The one error type that bad user input turns into.

Every problem with a scene file or a command-line argument becomes an ``InputError``
naming the file and the key; the CLI prints it on one line and exits with code 2.
"""

from __future__ import annotations

EXIT_BAD_INPUT = 2


class InputError(Exception):
    """Bad input: ``file: key: message``."""

    def __init__(self, file: str, key: str, message: str) -> None:
        self.file = str(file)
        self.key = key
        self.message = message
        super().__init__(f"{self.file}: {key}: {message}" if key else f"{self.file}: {message}")
