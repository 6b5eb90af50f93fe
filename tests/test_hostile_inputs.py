"""Hostile input: every bad file, value or option ends in a one-line error, fast, before any simulation.

Each case runs the real command line (typer's ``CliRunner``, in process, under a 10 s alarm; the
failures issue 11 found — hangs, 7 TiB allocations, tracebacks after the simulation — also as real
subprocesses under ``timeout``) or the Python API, and checks: a non-zero exit (2: bad input), one
``error:`` line, the file or field named in it, and the time bound.
"""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest
from typer.testing import CliRunner

from pbr_xval.cli import app

LIMIT = 10.0  # s: the bound for every hostile input

BASE = """\
name = "block"
duration = 2.0
settle_time = 0.2
output_dt = 0.001

[rock]
shape = "box"
half_extents = [0.2, 0.2, 0.6]
density = 2400.0

[contact]
friction_static = 2.0

[excitation]
type = "half_sine"
amplitude = 5.0
frequency = 1.0
phase = "housner_uplift"

[toppling]
criterion = "critical_tilt"
"""

CATALOG = """\
name = "tiny"
duration = 1.0
engines = ["housner"]

[[rock]]
id = "block"
shape = "box"
half_extents = [0.2, 0.2, 0.6]
density = 2400.0

[[motions.pulse]]
type = "half_sine"
amplitude = [2.0, 8.0]
"""


class Timeout(Exception):
    pass


@contextmanager
def within(seconds: float) -> Iterator[None]:
    """Raise :class:`Timeout` in the main thread if the block runs longer than ``seconds``."""

    def alarm(signum: int, frame: object) -> None:
        raise Timeout(f"still running after {seconds} s")

    old = signal.signal(signal.SIGALRM, alarm)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


def edit(text: str, old: str, new: str) -> str:
    assert text.count(old) == 1, old
    return text.replace(old, new)


def box_obj(path: Path, size: float = 1.0) -> None:
    """A closed box mesh, 0.4 × 0.4 × 1.2 ``size`` units, resting on z = 0, as OBJ."""
    hx, hz = 0.2 * size, 1.2 * size
    v = [(x, y, z) for x in (-hx, hx) for y in (-hx, hx) for z in (0.0, hz)]
    faces = [(1, 2, 4), (1, 4, 3), (5, 7, 8), (5, 8, 6), (1, 5, 6), (1, 6, 2),
             (3, 4, 8), (3, 8, 7), (1, 3, 7), (1, 7, 5), (2, 6, 8), (2, 8, 4)]  # fmt: skip
    lines = [f"v {x} {y} {z}" for x, y, z in v] + [f"f {a} {b} {c}" for a, b, c in faces]
    path.write_text("\n".join(lines) + "\n")


MESH_ROCK = """[rock]
shape = "mesh"
path = "box.obj"
units = "UNITS"
pose = "scan"
density = 2400.0
"""

# (id, scenario text (or None: write nothing / a special file), extra CLI args, text the error must contain)
# The command is `run SCENARIO -e housner --out <tmp>/t.parquet` unless the args start with a command.
SCENARIO_CASES: list[tuple[str, str | None, list[str], str]] = [
    ("toml-syntax", "name = \n", [], "not valid TOML"),
    ("empty-file", "", [], "empty"),
    ("missing-file", None, [], "cannot read scenario file"),
    ("binary-file", "\x00\xff\xfe garbage", [], "s.toml"),
    ("unknown-top-key", BASE + "durration = 3.0\n", [], "durration"),
    ("duration-negative", edit(BASE, "duration = 2.0", "duration = -1.0"), [], "duration"),
    ("duration-zero", edit(BASE, "duration = 2.0", "duration = 0.0"), [], "duration"),
    ("duration-nan", edit(BASE, "duration = 2.0", "duration = nan"), [], "duration"),
    ("duration-inf", edit(BASE, "duration = 2.0", "duration = inf"), [], "duration"),
    ("duration-string", edit(BASE, "duration = 2.0", 'duration = "two"'), [], "duration"),
    ("duration-1e9", edit(BASE, "duration = 2.0", "duration = 1e9"), [], "samples"),
    ("output-dt-zero", edit(BASE, "output_dt = 0.001", "output_dt = 0.0"), [], "output_dt"),
    ("output-dt-negative", edit(BASE, "output_dt = 0.001", "output_dt = -0.001"), [], "output_dt"),
    ("settle-negative", edit(BASE, "settle_time = 0.2", "settle_time = -1.0"), [], "settle_time"),
    ("gravity-zero", "gravity = 0.0\n" + BASE, [], "gravity"),
    ("density-negative", edit(BASE, "density = 2400.0", "density = -1.0"), [], "rock.density"),
    ("density-zero", edit(BASE, "density = 2400.0", "density = 0.0"), [], "rock.density"),
    ("density-nan", edit(BASE, "density = 2400.0", "density = nan"), [], "rock.density"),
    ("density-1e308", edit(BASE, "density = 2400.0", "density = 1e308"), [], "rock.density"),
    ("mass-absurd", edit(BASE, "density = 2400.0", "mass = 1e30"), [], "rock.mass"),
    ("mass-and-density", edit(BASE, "density = 2400.0", "density = 2400.0\nmass = 10.0"), [], "rock"),
    ("half-extents-short", edit(BASE, "[0.2, 0.2, 0.6]", "[0.2, 0.2]"), [], "rock.half_extents"),
    ("half-extents-negative", edit(BASE, "[0.2, 0.2, 0.6]", "[0.2, -0.2, 0.6]"), [], "rock.half_extents"),
    ("rock-6000-km", edit(BASE, "[0.2, 0.2, 0.6]", "[2e6, 2e6, 6e6]"), [], "m across"),
    ("rock-shape-unknown", edit(BASE, 'shape = "box"', 'shape = "sphere"'), [], "rock"),
    (
        "mesh-missing",
        edit(
            BASE,
            BASE[BASE.index("[rock]") : BASE.index("[contact]")],
            MESH_ROCK.replace("UNITS", "m").replace("box.obj", "nothing.obj") + "\n",
        ),
        [],
        "rock.path",
    ),
    (
        "mesh-in-km",
        edit(
            BASE,
            BASE[BASE.index("[rock]") : BASE.index("[contact]")],
            MESH_ROCK.replace("UNITS", "km") + "\n",
        ),
        [],
        "rock.units",
    ),
    (
        "friction-negative",
        edit(BASE, "friction_static = 2.0", "friction_static = -0.5"),
        [],
        "contact.friction_static",
    ),
    (
        "restitution-above-1",
        BASE.replace("[contact]\n", "[contact]\nrestitution = 1.5\n"),
        [],
        "contact.restitution",
    ),
    ("amplitude-zero", edit(BASE, "amplitude = 5.0", "amplitude = 0.0"), [], "excitation.amplitude"),
    ("frequency-negative", edit(BASE, "frequency = 1.0", "frequency = -1.0"), [], "excitation.frequency"),
    ("excitation-type-unknown", edit(BASE, 'type = "half_sine"', 'type = "earthquake"'), [], "excitation"),
    (
        "azimuth-inf",
        BASE.replace('phase = "housner_uplift"', 'phase = "housner_uplift"\nazimuth_deg = inf'),
        [],
        "azimuth_deg",
    ),
    (
        "record-missing",
        edit(
            BASE,
            BASE[BASE.index("[excitation]") : BASE.index("[toppling]")],
            '[excitation]\ntype = "record"\npath = "none.at2"\n\n',
        ),
        [],
        "excitation.path",
    ),
    (
        "record-truncated-at2",
        edit(
            BASE,
            BASE[BASE.index("[excitation]") : BASE.index("[toppling]")],
            '[excitation]\ntype = "record"\npath = "one.at2"\n\n',
        ),
        [],
        "excitation.path",
    ),
    (
        "record-nan-sample",
        edit(
            BASE,
            BASE[BASE.index("[excitation]") : BASE.index("[toppling]")],
            '[excitation]\ntype = "record"\npath = "nan.txt"\ndt = 0.01\nunits = "g"\n\n',
        ),
        [],
        "nan.txt",
    ),
    (
        "record-empty",
        edit(
            BASE,
            BASE[BASE.index("[excitation]") : BASE.index("[toppling]")],
            '[excitation]\ntype = "record"\npath = "empty.txt"\ndt = 0.01\nunits = "g"\n\n',
        ),
        [],
        "empty.txt",
    ),
    (
        "mesh-garbage",
        edit(
            BASE,
            BASE[BASE.index("[rock]") : BASE.index("[contact]")],
            MESH_ROCK.replace("UNITS", "m").replace("box.obj", "garbage.obj") + "\n",
        ),
        [],
        "garbage.obj",
    ),
    ("name-with-space", edit(BASE, 'name = "block"', 'name = "my block"'), [], "name"),
    ("toppling-criterion-unknown", edit(BASE, '"critical_tilt"', '"falls"'), [], "toppling.criterion"),
    ("toppling-factor-zero", BASE + "factor = 0.0\n", [], "toppling.factor"),
    ("engines-typo", BASE + "\n[engines.bulletx]\ntimestep = 0.001\n", [], "bulletx"),
    ("engines-timestep-negative", BASE + "\n[engines.reference]\ntimestep = -0.001\n", [], "timestep"),
    ("engines-iterations-zero", BASE + "\n[engines.mujoco]\niterations = 0\n", [], "iterations"),
    ("engines-tolerance-nan", BASE + "\n[engines.mujoco]\ntolerance = nan\n", [], "tolerance"),
    ("engines-key-typo", BASE + "\n[engines.mujoco]\ntimestepp = 0.001\n", [], "timestepp"),
    ("engines-not-a-table", BASE + "\n[engines]\nmujoco = 3\n", [], "engines.mujoco"),
    # the run command's options
    ("set-timestep-zero", BASE, ["-e", "reference", "--set", "timestep=0"], "timestep"),
    ("engine-set-timestep-negative", BASE, ["-e", "reference", "--engine-set", "timestep=-1e-3"], "timestep"),
    ("engine-set-iterations-zero", BASE, ["-e", "reference", "--engine-set", "iterations=0"], "iterations"),
    (
        "engine-set-tolerance-zero",
        BASE,
        ["-e", "reference", "--engine-set", "iteration_tol=0"],
        "iteration_tol",
    ),
    ("engine-set-tiny-timestep", BASE, ["-e", "mujoco", "--engine-set", "timestep=1e-9"], "steps"),
    ("engine-set-timestep-huge", BASE, ["-e", "pybullet", "--engine-set", "timestep=5"], "timestep"),
    ("engine-set-nan", BASE, ["--engine-set", "rtol=NaN"], "rtol"),
    ("engine-set-bad-variant", BASE, ["--engine-set", "variant=bogus"], "variant"),
    ("engine-set-bad-type", BASE, ["-e", "mujoco", "--engine-set", "integrator=3"], "integrator"),
    ("engine-set-unknown", BASE, ["--engine-set", "rtoll=1"], "rtoll"),
    ("set-scenario-negative", BASE, ["--set", "excitation.amplitude=-3"], "excitation.amplitude"),
    ("set-unknown-key", BASE, ["--set", "excitation.amplitudee=3"], "amplitudee"),
    ("set-no-equals", BASE, ["--set", "duration"], "key=value"),
    ("engine-unknown", BASE, ["-e", "bulletx"], "bulletx"),
    ("profile-unknown", BASE, ["--profile", "fastest"], "fastest"),
    ("out-file-exists", BASE, ["--out", "{tmp}/exists.parquet"], "--overwrite"),
    ("out-parent-is-file", BASE, ["--out", "{tmp}/exists.parquet/t.parquet"], "is a file"),
    # threshold (scan options)
    ("threshold-n-grid-1", BASE, ["threshold", "--n-grid", "1"], "n_grid"),
    ("threshold-rel-tol-zero", BASE, ["threshold", "--rel-tol", "0"], "rel_tol"),
    ("threshold-lo-above-hi", BASE, ["threshold", "--lo", "9", "--hi", "2"], "lo"),
    ("threshold-param-unknown", BASE, ["threshold", "--param", "excitation.amplitudee"], "amplitudee"),
]


def _error_lines(output: str) -> list[str]:
    return [ln for ln in output.splitlines() if ln.lower().startswith("error")]


def _check(code: int, output: str, needle: str, elapsed: float) -> None:
    assert code != 0, f"exit code 0:\n{output}"
    assert "Traceback" not in output, output
    lines = _error_lines(output)
    assert len(lines) == 1, f"expected one error line, got:\n{output}"
    assert needle.lower() in lines[0].lower(), f"{needle!r} not in {lines[0]!r}"
    assert elapsed < LIMIT, f"took {elapsed:.1f} s"


@pytest.mark.parametrize(
    ("text", "args", "needle"), [c[1:] for c in SCENARIO_CASES], ids=[c[0] for c in SCENARIO_CASES]
)
def test_scenario_cli(tmp_path: Path, text: str | None, args: list[str], needle: str) -> None:
    scn = tmp_path / "s.toml"
    if text is not None:
        if "\x00" in text:
            scn.write_bytes(text.encode("latin-1"))
        else:
            scn.write_text(text)
    box_obj(tmp_path / "box.obj", size=5.0)  # 2 × 2 × 6 units: 6,000 km in km
    (tmp_path / "garbage.obj").write_text("not a mesh\n")
    (tmp_path / "one.at2").write_text("x")
    (tmp_path / "nan.txt").write_text("0.1\nnan\n0.2\n")
    (tmp_path / "empty.txt").write_text("")
    (tmp_path / "exists.parquet").write_bytes(b"not yours")
    args = [a.replace("{tmp}", str(tmp_path)) for a in args]
    if args and args[0] == "threshold":
        cmd = ["threshold", str(scn), "-e", "housner", *args[1:]]
    else:
        cmd = ["run", str(scn)]
        if "-e" not in args:
            cmd += ["-e", "housner"]
        cmd += args
        if "--out" not in args:
            cmd += ["--out", str(tmp_path / "t.parquet")]
    t0 = time.perf_counter()
    with within(LIMIT):
        res = CliRunner().invoke(app, cmd)
    _check(res.exit_code, res.output, needle, time.perf_counter() - t0)
    assert not (tmp_path / "t.parquet").exists()  # nothing was simulated or written
    assert (tmp_path / "exists.parquet").read_bytes() == b"not yours"


# click's own usage errors (missing arguments, unknown options, values of the wrong type) come in
# typer's framed panel: exit 2 and the argument or option named, no traceback
USAGE_CASES = [
    ("run-no-scenario", ["run"], "SCENARIO"),
    ("run-no-engine", ["run", "{scn}"], "--engine"),
    ("run-unknown-option", ["run", "{scn}", "-e", "housner", "--bogus"], "--bogus"),
    ("threshold-n-grid-text", ["threshold", "{scn}", "-e", "housner", "--n-grid", "many"], "--n-grid"),
    ("sweep-no-out", ["sweep", "{scn}"], "OUT"),
    ("sweep-workers-text", ["sweep", "{scn}", "{tmp}/st", "--workers", "two"], "--workers"),
]


@pytest.mark.parametrize(("args", "needle"), [c[1:] for c in USAGE_CASES], ids=[c[0] for c in USAGE_CASES])
def test_usage_errors(tmp_path: Path, args: list[str], needle: str) -> None:
    (tmp_path / "s.toml").write_text(BASE)
    args = [a.replace("{scn}", str(tmp_path / "s.toml")).replace("{tmp}", str(tmp_path)) for a in args]
    t0 = time.perf_counter()
    with within(LIMIT):
        res = CliRunner().invoke(app, args)
    assert res.exit_code == 2 and "Traceback" not in res.output, res.output
    assert needle.lower() in res.output.lower() and time.perf_counter() - t0 < LIMIT


# ------------------------------------------------------------------ catalogs
CATALOG_CASES: list[tuple[str, str | None, list[str], str]] = [
    ("catalog-missing", None, [], "cannot read catalog"),
    ("catalog-empty", "", [], "rock"),
    ("catalog-toml-syntax", "name = [\n", [], "not valid TOML"),
    ("catalog-engine-unknown", edit(CATALOG, '["housner"]', '["bulletx"]'), [], "engines[0]"),
    (
        "catalog-settings-engine-unknown",
        CATALOG + "\n[settings.bulletx]\ntimestep = 0.001\n",
        [],
        "settings.bulletx",
    ),
    (
        "catalog-settings-timestep-zero",
        CATALOG + "\n[settings.mujoco]\ntimestep = 0.0\n",
        [],
        "settings.mujoco",
    ),
    ("catalog-settings-key-typo", CATALOG + "\n[settings.housner]\nrtoll = 1e-8\n", [], "rtoll"),
    ("catalog-duration-1e9", edit(CATALOG, "duration = 1.0", "duration = 1e9"), [], "samples"),
    ("catalog-density-negative", edit(CATALOG, "density = 2400.0", "density = -5.0"), [], "density"),
    ("catalog-rocks-csv-missing", CATALOG + 'rocks_csv = "none.csv"\n', [], "rocks_csv"),
    ("catalog-no-motions", CATALOG[: CATALOG.index("[[motions.pulse]]")], [], "motions"),
    ("sweep-out-is-a-file", CATALOG, ["{tmp}/afile"], "is a file"),
    ("sweep-engine-unknown", CATALOG, ["-e", "bulletx"], "bulletx"),
    ("sweep-workers-zero", CATALOG, ["--workers", "0"], "--workers"),
    ("sweep-chunk-size-negative", CATALOG, ["--chunk-size", "-1"], "--chunk-size"),
    ("sweep-shard-bad", CATALOG, ["--shard", "3/2"], "shard"),
    ("sweep-executor-unknown", CATALOG, ["--executor", "threads"], "executor"),
    ("choose-budget-negative", CATALOG, ["choose", "--budget", "-1"], "budget"),
    ("choose-budget-text", CATALOG, ["choose", "--budget", "lots"], "budget"),
    ("choose-out-is-a-file", CATALOG, ["choose", "--out", "{tmp}/afile"], "is a file"),
]


@pytest.mark.parametrize(
    ("text", "args", "needle"), [c[1:] for c in CATALOG_CASES], ids=[c[0] for c in CATALOG_CASES]
)
def test_catalog_cli(tmp_path: Path, text: str | None, args: list[str], needle: str) -> None:
    cat = tmp_path / "c.toml"
    if text is not None:
        cat.write_text(text)
    (tmp_path / "afile").write_text("mine")
    args = [a.replace("{tmp}", str(tmp_path)) for a in args]
    if args and args[0] == "choose":
        cmd = ["choose", str(cat), *args[1:]]
        if "--out" not in args:
            cmd += ["--out", str(tmp_path / "choose")]
    elif args and not args[0].startswith("-"):
        cmd = ["sweep", str(cat), *args]
    else:
        cmd = ["sweep", str(cat), str(tmp_path / "store"), *args]
    t0 = time.perf_counter()
    with within(LIMIT):
        res = CliRunner().invoke(app, cmd)
    _check(res.exit_code, res.output, needle, time.perf_counter() - t0)
    assert not (tmp_path / "store").exists() and (tmp_path / "afile").read_text() == "mine"


# ------------------------------------------------------------------ the Python API
def _api_cases() -> list[tuple[str, Callable[[Path], object], type[Exception], str]]:
    from pbr_xval.catalog import CatalogError, load_catalog
    from pbr_xval.engine import EngineNotAvailable, EngineSettingsError, get_engine, merge_settings
    from pbr_xval.runner import run_scenario
    from pbr_xval.scenario import ScenarioError, load_scenario

    def scn(tmp: Path, text: str = BASE) -> Path:
        (tmp / "s.toml").write_text(text)
        return tmp / "s.toml"

    return [
        (
            "load-bad-density",
            lambda t: load_scenario(scn(t, edit(BASE, "2400.0", "-1.0"))),
            ScenarioError,
            "s.toml",
        ),
        (
            "resolve-timestep-zero",
            lambda t: get_engine("reference").resolve_settings({"timestep": 0}),
            EngineSettingsError,
            "timestep",
        ),
        (
            "merge-iterations-negative",
            lambda t: merge_settings("mujoco", {"iterations": 100}, {"iterations": -1}),
            EngineSettingsError,
            "iterations",
        ),
        (
            "run-density-1e308",
            lambda t: run_scenario(load_scenario(scn(t, edit(BASE, "2400.0", "1e308"))), "mujoco"),
            ScenarioError,
            "rock.density",
        ),
        (
            "run-timestep-zero",
            lambda t: run_scenario(load_scenario(scn(t)), "reference", {"timestep": 0.0}),
            EngineSettingsError,
            "timestep",
        ),
        (
            "with-value-duration-1e9",
            lambda t: load_scenario(scn(t)).with_value("duration", 1e9),
            ScenarioError,
            "samples",
        ),
        (
            "catalog-engine-unknown",
            lambda t: load_catalog(
                (t / "c.toml", (t / "c.toml").write_text(edit(CATALOG, '["housner"]', '["bulletx"]')))[0]
            ),
            CatalogError,
            "bulletx",
        ),
        ("engine-unknown", lambda t: get_engine("bulletx"), EngineNotAvailable, "bulletx"),
    ]


API_IDS = ["load-bad-density", "resolve-timestep-zero", "merge-iterations-negative", "run-density-1e308",
           "run-timestep-zero", "with-value-duration-1e9", "catalog-engine-unknown", "engine-unknown"]  # fmt: skip


@pytest.mark.parametrize("case", API_IDS)
def test_python_api(tmp_path: Path, case: str) -> None:
    cases = {c[0]: c[1:] for c in _api_cases()}
    assert set(cases) == set(API_IDS)
    fn, exc_type, needle = cases[case]
    t0 = time.perf_counter()
    with within(LIMIT), pytest.raises(exc_type) as info:
        fn(tmp_path)
    assert time.perf_counter() - t0 < LIMIT
    msg = str(info.value)
    assert needle in msg and len(msg.splitlines()) == 1, msg


# ------------------------------------------------------------------ real processes (hangs fail, not block)
SUBPROCESS_CASES = [
    ("reference-timestep-zero-hang", BASE, ["-e", "reference", "--set", "timestep=0"], "timestep"),
    (
        "reference-negative-timestep-table",
        BASE + "\n[engines.reference]\ntimestep = -0.001\n",
        ["-e", "reference"],
        "timestep",
    ),
    ("mujoco-duration-1e9", edit(BASE, "duration = 2.0", "duration = 1e9"), ["-e", "mujoco"], "samples"),
    (
        "mujoco-density-1e308",
        edit(BASE, "density = 2400.0", "density = 1e308"),
        ["-e", "mujoco"],
        "rock.density",
    ),
]


def _cli(*args: str, cwd: Path) -> tuple[int, str, float]:
    exe = Path(sys.executable).parent / "pbr-xval"
    cmd = [str(exe)] if exe.exists() else [sys.executable, "-m", "pbr_xval.cli"]
    env = {**os.environ, "COLUMNS": "80"}  # a narrow terminal must not wrap the message
    t0 = time.perf_counter()
    try:
        res = subprocess.run(
            ["timeout", "-s", "KILL", str(LIMIT + 5), *cmd, *args], cwd=cwd, env=env,
            capture_output=True, text=True, timeout=LIMIT + 10,
        )  # fmt: skip
    except subprocess.TimeoutExpired:
        pytest.fail(f"{args}: no answer within {LIMIT + 10} s")
    return res.returncode, res.stdout + res.stderr, time.perf_counter() - t0


@pytest.mark.parametrize(
    ("text", "args", "needle"), [c[1:] for c in SUBPROCESS_CASES], ids=[c[0] for c in SUBPROCESS_CASES]
)
def test_subprocess(tmp_path: Path, text: str, args: list[str], needle: str) -> None:
    (tmp_path / "s.toml").write_text(text)
    code, out, elapsed = _cli("run", "s.toml", *args, "--out", "t.parquet", cwd=tmp_path)
    assert code not in (-9, 124, 137), f"killed after {elapsed:.1f} s (hang):\n{out}"
    _check(code, out, needle, elapsed)
    assert not (tmp_path / "t.parquet").exists()


def test_sweep_into_existing_file_subprocess(tmp_path: Path) -> None:
    (tmp_path / "c.toml").write_text(CATALOG)
    (tmp_path / "results").write_text("mine")
    code, out, elapsed = _cli("sweep", "c.toml", "results", cwd=tmp_path)
    _check(code, out, "results", elapsed)
    assert (tmp_path / "results").read_text() == "mine"


def test_run_out_existing_folder_writes_inside(tmp_path: Path) -> None:
    """`run --out DIR` with DIR an existing folder writes DIR/<name>.<engine>.parquet (it used to crash after the run)."""
    (tmp_path / "s.toml").write_text(BASE)
    (tmp_path / "runs").mkdir()
    with within(LIMIT):
        res = CliRunner().invoke(
            app, ["run", str(tmp_path / "s.toml"), "-e", "housner", "--out", str(tmp_path / "runs")]
        )
    assert res.exit_code == 0, res.output
    assert (tmp_path / "runs" / "block.housner.parquet").is_file()


# ------------------------------------------------------------------ stale temporaries and file modes
def _dead_pid() -> int:
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    p.wait()
    return p.pid


def test_stale_temporaries_are_cleaned_by_the_next_write(tmp_path: Path) -> None:
    from pbr_xval.atomic import _host, write_text_atomic

    dead = _dead_pid()
    stale = tmp_path / f".chunk.parquet.pid{dead}@{_host()}.abcd1234.tmp"
    live = tmp_path / f".chunk.parquet.pid{os.getpid()}@{_host()}.abcd1234.tmp"
    remote = tmp_path / f".chunk.parquet.pid{dead}@some-other-node.abcd1234.tmp"
    old_style = tmp_path / ".other.parquet.k2j4h5g6.tmp"
    new_old_style = tmp_path / ".fresh.parquet.a1b2c3d4.tmp"
    for p in (stale, live, remote, old_style, new_old_style):
        p.write_text("partial")
    day_ago = time.time() - 2 * 86400
    os.utime(old_style, (day_ago, day_ago))
    write_text_atomic(tmp_path / "x.txt", "hello")
    assert not stale.exists() and not old_style.exists()  # the dead writer's and a days-old one
    assert live.exists() and remote.exists() and new_old_style.exists()  # alive, elsewhere, recent
    assert (tmp_path / "x.txt").read_text() == "hello"


def test_stale_report_folders_are_cleaned_by_the_next_report(tmp_path: Path) -> None:
    from pbr_xval.report.writer import write_report

    dead = _dead_pid()
    stale = tmp_path / f"rep.tmp-{dead}"
    stale.mkdir()
    (stale / "index.html").write_text("half a report")
    live = tmp_path / f"other.tmp-{os.getppid()}"
    live.mkdir()
    write_report([], tmp_path / "rep", provenance={}, title="empty")
    assert not stale.exists() and live.exists()
    assert (tmp_path / "rep" / "index.html").is_file()


def test_sweep_cleans_stale_store_temporaries(tmp_path: Path) -> None:
    from pbr_xval.atomic import _host

    store = tmp_path / "store" / "engine=housner" / "rock=block"
    store.mkdir(parents=True)
    stale = store / f".abc.parquet.pid{_dead_pid()}@{_host()}.zzzz9999.tmp"
    stale.write_text("partial chunk")
    (tmp_path / "c.toml").write_text(CATALOG)
    with within(60):
        res = CliRunner().invoke(
            app, ["sweep", str(tmp_path / "c.toml"), str(tmp_path / "store"), "--executor", "inline"]
        )
    assert res.exit_code == 0, res.output
    assert not stale.exists()


def test_files_honour_the_umask(tmp_path: Path) -> None:
    from pbr_xval.atomic import write_bytes_atomic

    old = os.umask(0o022)
    try:
        write_bytes_atomic(tmp_path / "a.bin", b"x")
        assert (tmp_path / "a.bin").stat().st_mode & 0o777 == 0o644
        os.umask(0o077)
        write_bytes_atomic(tmp_path / "b.bin", b"x")
        assert (tmp_path / "b.bin").stat().st_mode & 0o777 == 0o600
    finally:
        os.umask(old)


def test_figures_are_atomic_and_honour_the_umask(tmp_path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from pbr_xval.atomic import write_figure_atomic

    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1])
    old = os.umask(0o022)
    try:
        write_figure_atomic(tmp_path / "f.png", fig, dpi=50)
    finally:
        os.umask(old)
        plt.close(fig)
    data = (tmp_path / "f.png").read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and (tmp_path / "f.png").stat().st_mode & 0o777 == 0o644
    assert [p.name for p in tmp_path.iterdir()] == ["f.png"]  # no temporary left


def test_case_count() -> None:
    """The issue's list had 63 hostile inputs; this file covers at least as many."""
    n = len(SCENARIO_CASES) + len(CATALOG_CASES) + len(USAGE_CASES) + len(API_IDS) + len(SUBPROCESS_CASES) + 2
    assert n >= 63, n
    assert math.isfinite(LIMIT)
