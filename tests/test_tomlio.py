"""pbr_xval.tomlio: TOML input files and pydantic errors as one-line messages naming file and key."""

from __future__ import annotations

from pathlib import Path
from typing import Literal

import pytest
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from pbr_xval.tomlio import error_parts, key_line, read_toml, resolve_path, validation_lines


class Oops(ValueError):
    pass


def _read(path: Path) -> dict:
    return read_toml(path, what="demo", expected="a [table]", error=Oops)


def test_read_toml_ok(tmp_path: Path) -> None:
    p = tmp_path / "a.toml"
    p.write_text("x = 1\n[t]\ny = 'z'\n")
    assert _read(p) == {"x": 1, "t": {"y": "z"}}


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (None, "cannot read demo file"),
        (b"\xff\xfe x = 1", "not a text file (byte 0 is not UTF-8); expected a demo TOML file"),
        (b"  \n", "empty file; expected a demo TOML (a [table])"),
        (b"x = = 1", "not valid TOML"),
    ],
)
def test_read_toml_errors(tmp_path: Path, content: bytes | None, message: str) -> None:
    p = tmp_path / "bad.toml"
    if content is not None:
        p.write_bytes(content)
    with pytest.raises(Oops) as info:
        _read(p)
    text = str(info.value)
    assert text.startswith(f"{p}: ") and message in text and "\n" not in text


def test_resolve_path(tmp_path: Path) -> None:
    assert resolve_path("m/rock.obj", tmp_path) == (tmp_path / "m" / "rock.obj").resolve()
    assert resolve_path("/abs/x", tmp_path) == Path("/abs/x")


class Inner(BaseModel):
    model_config = ConfigDict(extra="forbid")
    kind: Literal["box"]
    size: float = Field(gt=0)


class Outer(BaseModel):
    model_config = ConfigDict(extra="forbid")
    name: str
    inner: Inner


def _errors(data: dict) -> ValidationError:
    with pytest.raises(ValidationError) as info:
        Outer.model_validate(data)
    return info.value


def test_validation_lines() -> None:
    exc = _errors({"inner": {"kind": "box", "size": -1, "colour": "red"}, "extra": 1})
    lines = validation_lines(
        exc, "f.toml", prefix="top", known_keys=lambda loc: ["a", "b"] if len(loc) == 1 else []
    )
    assert "f.toml: key 'top.name': missing required key" in lines
    assert "f.toml: key 'top.inner.size': Input should be greater than 0 (found -1)" in lines
    assert "f.toml: key 'top.inner.colour': unknown key (found 'red')" in lines
    assert "f.toml: key 'top.extra': unknown key; expected one of: a, b (found 1)" in lines


def test_error_parts_drop_tables_and_tags() -> None:
    exc = _errors({"name": "n", "inner": "not a table"})
    key, msg, found = error_parts(exc.errors()[0])
    assert key == "inner" and found == "not a table"
    exc = _errors({"name": "n", "inner": {"kind": "box"}})
    key, msg, found = error_parts(exc.errors()[0], loc=lambda loc: [p for p in map(str, loc) if p != "inner"])
    assert (key, msg, found) == ("size", "missing required key", None)


def test_key_line() -> None:
    assert key_line("w", "k", "bad", 3, "a number < 2") == "w: key 'k': bad (found 3); expected a number < 2"
    assert key_line("w", "k", "bad") == "w: key 'k': bad"
