"""Package discovery for pbr-xval (all other metadata lives in ``pyproject.toml``).

Three source trees form one import package: ``pbr_xval/`` → ``pbr_xval``, ``engines/`` →
``pbr_xval.engines``, ``reference/`` → ``pbr_xval.reference`` (the ``package-dir`` mapping in
``pyproject.toml``). ``[tool.setuptools.packages.find]`` cannot remap a directory to a dotted
name, so every folder with an ``__init__.py`` under the three trees is found here: a new
subpackage lands in the wheel without editing a list (``tests/test_packaging.py`` checks it).
"""

from pathlib import Path

from setuptools import setup

ROOT = Path(__file__).resolve().parent
TREES = {"pbr_xval": "pbr_xval", "pbr_xval.engines": "engines", "pbr_xval.reference": "reference"}


def _packages() -> list[str]:
    out: set[str] = set()
    for name, folder in TREES.items():
        base = ROOT / folder
        for init in base.rglob("__init__.py"):
            rel = init.parent.relative_to(base).parts
            if any(p.startswith(".") or p == "__pycache__" for p in rel):
                continue
            out.add(".".join((name, *rel)))
    return sorted(out)


setup(packages=_packages())
