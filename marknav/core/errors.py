"""Errors the CLI turns into exit codes.

- :class:`InputError` — bad input (file, table, mission, world, image, port): exit code 2.
  Its text names the file, line, column and field where they are known, formatted as
  ``FILE:LINE:COLUMN: field.path: message`` so editors can jump to it.
- :class:`MissionFailed` — the mission (or an evaluation) failed or was aborted: exit code 1.
"""

from __future__ import annotations

#: Exit codes of every command (the CLI contract).
EXIT_OK = 0
EXIT_FAILED = 1
EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130


class MarknavError(Exception):
    """Base class of the errors marknav raises on purpose."""

    exit_code = EXIT_FAILED


class InputError(MarknavError):
    """Bad input from the user: a file, a table row, a mission field, a device name."""

    exit_code = EXIT_BAD_INPUT

    def __init__(
        self,
        message: str,
        *,
        file: str | None = None,
        line: int | None = None,
        column: int | None = None,
        field: str | None = None,
    ) -> None:
        super().__init__(message)
        self.message = message
        self.file = file
        self.line = line
        self.column = column
        self.field = field

    def __str__(self) -> str:
        where = ""
        if self.file is not None:
            where = str(self.file)
            if self.line is not None:
                where += f":{self.line}"
                if self.column is not None:
                    where += f":{self.column}"
            where += ": "
        field = f"{self.field}: " if self.field else ""
        return f"{where}{field}{self.message}"


class InputErrors(InputError):
    """Several input errors found at once (all of a mission file's problems, not only the first)."""

    def __init__(self, errors: list[InputError]) -> None:
        if not errors:
            raise ValueError("InputErrors needs at least one error")
        super().__init__(errors[0].message, file=errors[0].file, line=errors[0].line,
                         column=errors[0].column, field=errors[0].field)
        self.errors = errors

    def __str__(self) -> str:
        return "\n".join(str(e) for e in self.errors)


class MissionFailed(MarknavError):
    """The mission or evaluation ran but did not succeed (exit code 1)."""

    exit_code = EXIT_FAILED
