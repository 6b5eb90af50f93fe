"""Reading the user's TOML input files: one-line errors naming the file and the key.

The shared plumbing of scenario, study and catalog files (a foundation module: imports nothing
from the package):

* :func:`read_toml` — read and parse a file; an unreadable, non-UTF-8, empty or malformed file
  is one line naming the file, what was found and what was expected;
* :func:`resolve_path` — a path written in a file, relative to that file's folder;
* :func:`error_parts`, :func:`validation_lines` — pydantic validation errors as
  ``<file>: key 'a.b': <message> (found <value>)`` lines, the one formatter of the package;
* :func:`key_line` — the same line for a check made by hand.

Each caller raises its own exception type (``ScenarioError``, ``StudyFileError``,
``CatalogError``) by passing it as ``error``.
"""

from __future__ import annotations

import tomllib
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from pydantic import ValidationError
    from pydantic_core import ErrorDetails

__all__ = ["error_parts", "key_line", "read_toml", "resolve_path", "validation_lines"]


def read_toml(
    path: str | Path, *, what: str, expected: str, error: Callable[[str], Exception]
) -> dict[str, Any]:
    """The parsed TOML tables of ``path``.

    Parameters
    ----------
    path : file to read.
    what : kind of file, for messages (``"scenario"``, ``"study"``, ``"catalog"``).
    expected : what an empty file should have held (e.g. ``"[[rock]] tables and [motions]"``).
    error : exception factory called with the one-line message.

    Raises
    ------
    Exception
        ``error(message)`` when the file cannot be read, is not UTF-8 text, is empty or is not
        valid TOML.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise error(f"{path}: cannot read {what} file ({exc.strerror})") from None
    except UnicodeDecodeError as exc:
        raise error(
            f"{path}: not a text file (byte {exc.start} is not UTF-8); expected a {what} TOML file"
        ) from None
    if not text.strip():
        raise error(f"{path}: empty file; expected a {what} TOML ({expected})")
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise error(f"{path}: not valid TOML: {exc}") from None


def resolve_path(p: str | Path, base: Path) -> Path:
    """``p`` (``~`` expanded) as an absolute path; a relative one is taken from ``base``."""
    q = Path(p).expanduser()
    return (q if q.is_absolute() else base / q).resolve()


def key_line(where: str, key: str, msg: str, found: Any = None, expected: str | None = None) -> str:
    """``<where>: key '<key>': <msg> (found <found>); expected <expected>`` (parts left out when None)."""
    text = f"{where}: key '{key}': {msg}"
    if found is not None:
        text += f" (found {found!r})"
    if expected:
        text += f"; expected {expected}"
    return text


def error_parts(
    err: ErrorDetails, *, prefix: str = "", loc: Callable[[tuple[Any, ...]], Iterable[str]] | None = None
) -> tuple[str, str, Any]:
    """(key, message, found) of one pydantic error.

    ``loc`` maps pydantic's location to key components (e.g. to drop discriminated-union
    tags); ``prefix`` is the table the model was validated at. ``found`` is None for a
    missing key and for a whole table (a dict).
    """
    parts = list(loc(tuple(err["loc"]))) if loc else [str(p) for p in err["loc"]]
    key = ".".join([prefix, *parts] if prefix else parts) or prefix or "?"
    found = err.get("input")
    if isinstance(found, dict):
        found = None
    if err["type"] == "missing":
        return key, "missing required key", None
    if err["type"] == "extra_forbidden":
        return key, "unknown key", found
    return key, err["msg"].removeprefix("Value error, "), found


def validation_lines(
    exc: ValidationError,
    where: str,
    *,
    prefix: str = "",
    loc: Callable[[tuple[Any, ...]], Iterable[str]] | None = None,
    known_keys: Callable[[tuple[Any, ...]], Iterable[str]] | None = None,
) -> list[str]:
    """One :func:`key_line` per error of ``exc``; an unknown key lists ``known_keys(loc)``."""
    lines = []
    for err in exc.errors():
        key, msg, found = error_parts(err, prefix=prefix, loc=loc)
        if err["type"] == "extra_forbidden" and known_keys is not None:
            known = sorted(known_keys(tuple(err["loc"])))
            if known:
                msg = f"unknown key; expected one of: {', '.join(known)}"
        lines.append(key_line(where, key, msg, found))
    return lines
