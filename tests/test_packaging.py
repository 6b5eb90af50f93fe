"""A real (non-editable) install: build the wheel, install it into a fresh venv, run the CLI from it.

CI installs the project with ``pip install -e``, which reads the source folders directly and so
cannot notice a package missing from the wheel (``pbr_xval.catalog`` once was). This test copies
the source trees to a temporary folder (the shared working tree gets no ``build/`` or
``*.egg-info``), builds the wheel without build isolation and without the network, and installs it
without dependencies into a fresh venv that sees this environment's third-party packages through a
``.pth`` path line (a plain path line does not run this environment's editable-install hook, so
``pbr_xval`` can only come from the wheel; the test checks where it was imported from).
"""

from __future__ import annotations

import os
import shutil
import site
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: import package -> source folder (the package-dir mapping of pyproject.toml)
TREES = {"pbr_xval": "pbr_xval", "pbr_xval.engines": "engines", "pbr_xval.reference": "reference"}
TIMEOUT = 120  # s per subprocess; the whole test takes ~10 s on the 2-core CI machine


def source_packages() -> set[str]:
    """Every folder with an ``__init__.py`` in the three source trees, as dotted package names."""
    out = set()
    for name, folder in TREES.items():
        base = ROOT / folder
        for init in base.rglob("__init__.py"):
            rel = init.parent.relative_to(base).parts
            if any(p.startswith(".") or p == "__pycache__" for p in rel):
                continue
            out.add(".".join((name, *rel)))
    return out


def wheel_packages(whl: Path) -> set[str]:
    with zipfile.ZipFile(whl) as z:
        names = z.namelist()
    return {n[: -len("/__init__.py")].replace("/", ".") for n in names if n.endswith("/__init__.py")}


def _run(cmd: list[str], cwd: Path, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    res = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=TIMEOUT)
    assert res.returncode == 0, f"{' '.join(map(str, cmd))} failed:\n{res.stdout}\n{res.stderr}"
    return res


@pytest.fixture(scope="module")
def wheel(tmp_path_factory: pytest.TempPathFactory) -> Path:
    tmp = tmp_path_factory.mktemp("wheel")
    src = tmp / "src"
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc", "*.egg-info", "build")
    for folder in {*TREES.values()}:
        shutil.copytree(ROOT / folder, src / folder, ignore=ignore)
    for f in ("pyproject.toml", "setup.py", "README.md"):
        shutil.copy2(ROOT / f, src / f)
    dist = tmp / "dist"
    _run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "--no-index", "-q",
         "-w", str(dist), str(src)],
        cwd=tmp,
    )  # fmt: skip
    (whl,) = dist.glob("pbr_xval-*.whl")
    return whl


@pytest.fixture(scope="module")
def venv(wheel: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    env_dir = tmp_path_factory.mktemp("venv") / "venv"
    _run([sys.executable, "-m", "venv", "--without-pip", str(env_dir)], cwd=env_dir.parent)
    py = env_dir / "bin" / "python"
    purelib = Path(
        subprocess.run(
            [py, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
            capture_output=True,
            text=True,
            check=True,
            timeout=TIMEOUT,
        ).stdout.strip()
    )
    # third-party dependencies from this environment, appended after the venv's own site-packages
    ours = [*site.getsitepackages(), sysconfig.get_paths()["purelib"], sysconfig.get_paths()["platlib"]]
    (purelib / "zz_parent_env.pth").write_text("\n".join(dict.fromkeys(ours)) + "\n")
    _run(
        [sys.executable, "-m", "pip", "--python", str(py), "install", "--no-deps", "--no-index", "-q",
         str(wheel)],
        cwd=env_dir.parent,
    )  # fmt: skip
    return env_dir


def _clean_env(venv: Path) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV")}
    env["PATH"] = f"{venv / 'bin'}{os.pathsep}{env.get('PATH', '')}"
    return env


def test_wheel_holds_every_package(wheel: Path) -> None:
    src = source_packages()
    got = wheel_packages(wheel)
    assert {"pbr_xval.catalog", "pbr_xval.cli", "pbr_xval.engines", "pbr_xval.reference"} <= src
    missing = sorted(src - got)
    assert not missing, f"packages missing from {wheel.name}: {missing}"


def test_installed_wheel_imports_from_the_venv(venv: Path) -> None:
    code = (
        "import pbr_xval, pbr_xval.catalog, pbr_xval.engines, pbr_xval.reference;"
        "print(pbr_xval.__file__); print(pbr_xval.catalog.__file__); print(pbr_xval.engines.__file__)"
    )
    res = _run([str(venv / "bin" / "python"), "-c", code], cwd=venv.parent, env=_clean_env(venv))
    paths = res.stdout.split()
    assert all(Path(p).resolve().is_relative_to(venv.resolve()) for p in paths), res.stdout


@pytest.mark.parametrize("command", ["sweep", "choose", "run"])
def test_installed_cli_help(venv: Path, command: str) -> None:
    res = _run([str(venv / "bin" / "pbr-xval"), command, "--help"], cwd=venv.parent, env=_clean_env(venv))
    assert "Usage" in res.stdout and command in res.stdout, res.stdout


def test_installed_sweep_runs(venv: Path) -> None:
    """A one-rock, two-motion housner sweep from the installed wheel writes its store."""
    work = venv.parent
    cat = work / "tiny.toml"
    cat.write_text(
        'name = "tiny"\nduration = 1.0\nengines = ["housner"]\nchunk_size = 2\n\n'
        '[[rock]]\nid = "block"\nshape = "box"\nhalf_extents = [0.2, 0.2, 0.6]\ndensity = 2400.0\n\n'
        '[[motions.pulse]]\ntype = "half_sine"\namplitude = [2.0, 8.0]\nfrequency = 1.0\n'
    )
    res = _run(
        [str(venv / "bin" / "pbr-xval"), "sweep", str(cat), str(work / "store"), "--executor", "inline"],
        cwd=work,
        env=_clean_env(venv),
    )
    files = list((work / "store").rglob("*.parquet"))
    assert len(files) == 1, res.stdout
