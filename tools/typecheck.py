"""Type-check pbr-xval with mypy, laid out as it is installed.

``engines/`` and ``reference/`` are installed as ``pbr_xval.engines`` and ``pbr_xval.reference``
(the package-dir mapping of ``pyproject.toml``). mypy cannot follow that mapping, nor the
import hook of an editable install, so this script mirrors the three trees into one
``pbr_xval`` package under ``build/typecheck/`` (kept between runs for mypy's cache), runs mypy
there with the ``[tool.mypy]`` settings of ``pyproject.toml``, and prints the messages with the
repository's own paths (``engines/mujoco_.py``, not ``pbr_xval/engines/mujoco_.py``).

Usage::

    python tools/typecheck.py [extra mypy options]

Exit status: mypy's (0 when there is no error).
"""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: folder in the mirror -> source folder in the repository
TREES = {"pbr_xval": "pbr_xval", "pbr_xval/engines": "engines", "pbr_xval/reference": "reference"}


def mirror(dest: Path) -> None:
    """Copy the three source trees into ``dest/pbr_xval`` (stale files removed, mtimes kept)."""
    pkg = dest / "pbr_xval"
    if pkg.exists():
        shutil.rmtree(pkg)
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc")
    for target, src in TREES.items():
        shutil.copytree(ROOT / src, dest / target, ignore=ignore, dirs_exist_ok=True)


def main(argv: list[str]) -> int:
    work = ROOT / "build" / "typecheck"
    work.mkdir(parents=True, exist_ok=True)
    mirror(work)
    res = subprocess.run(
        [sys.executable, "-m", "mypy", "--config-file", str(ROOT / "pyproject.toml"), "pbr_xval", *argv],
        cwd=work,
        capture_output=True,
        text=True,
    )
    back = re.compile(r"^pbr_xval/(engines|reference)/", re.MULTILINE)
    sys.stdout.write(back.sub(r"\1/", res.stdout))
    sys.stderr.write(res.stderr)
    return res.returncode


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
