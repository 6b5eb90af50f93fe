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

LIMIT = 10.0  # s: the issue's bound for every hostile input

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
    assert "np.float64" not in output, output  # plain numbers in messages
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


# ================================================================== issue 21: the 43 cases a hostile user found
# Every command with an output checks it before any work (one shared helper, pbr_xval.atomic.check_output_*);
# validate, sweep, fragility, threshold, rock and the record reader refuse the rest in one line, up front.


def _read_only(tmp: Path) -> Path:
    """A folder nothing can be written into: chmod 0555 (or, for root, who ignores modes, under /sys)."""
    if os.geteuid() == 0:
        return Path("/sys/pbr_xval_hostile")  # its nearest existing folder, /sys, refuses new files
    ro = tmp / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    return ro


def _snapshot(tmp: Path) -> dict[str, bytes | None]:
    return {
        str(p.relative_to(tmp)): (p.read_bytes() if p.is_file() else None) for p in sorted(tmp.rglob("*"))
    }


def _work(args: list[str]) -> tuple[int, str, float]:
    """Run legitimate input (real work: more than the refusals' bound)."""
    return _invoke(args, 120.0)


def _invoke(args: list[str], limit: float = LIMIT) -> tuple[int, str, float]:
    t0 = time.perf_counter()
    with within(limit):
        res = CliRunner().invoke(app, args)
    crash = res.exception if res.exception and not isinstance(res.exception, SystemExit) else None
    return res.exit_code, res.output + (f"\nraised {crash!r}" if crash else ""), time.perf_counter() - t0


def _two_boxes_obj(path: Path) -> None:
    """Two disjoint closed boxes: 0.4 × 0.4 × 1.2 m at the origin and a 0.2 m cube 2 m away (OBJ)."""

    def box(lo: tuple[float, float, float], hi: tuple[float, float, float], k: int) -> list[str]:
        v = [(x, y, z) for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]
        faces = [(1, 2, 4), (1, 4, 3), (5, 7, 8), (5, 8, 6), (1, 5, 6), (1, 6, 2),
                 (3, 4, 8), (3, 8, 7), (1, 3, 7), (1, 7, 5), (2, 6, 8), (2, 8, 4)]  # fmt: skip
        return [f"v {x} {y} {z}" for x, y, z in v] + [f"f {a + k} {b + k} {c + k}" for a, b, c in faces]

    lines = box((-0.2, -0.2, 0.0), (0.2, 0.2, 1.2), 0) + box((2.0, 2.0, 0.0), (2.2, 2.2, 0.2), 8)
    path.write_text("\n".join(lines) + "\n")


def _outputs_fixture(tmp: Path) -> dict[str, str]:
    """Inputs for every command with an output: a scenario, a scan, a campaign, a catalog, an empty store."""
    (tmp / "s.toml").write_text(BASE)
    (tmp / "c.toml").write_text(CATALOG)
    box_obj(tmp / "box.obj")
    (tmp / "afile").write_text("mine")
    (tmp / "old.toml").write_text("# the user's own scenario\n")
    (tmp / "store").mkdir()
    camp = tmp / "camp"
    camp.mkdir()
    (camp / "m1.txt").write_text("\n".join(f"{0.5 * math.sin(0.05 * i):.6f}" for i in range(400)) + "\n")
    (camp / "campaign.csv").write_text("test,motion_file,units,dt,toppled\n1,m1.txt,m/s2,0.005,0\n")
    return {
        "tmp": str(tmp),
        "ro": str(_read_only(tmp)),
        "scn": str(tmp / "s.toml"),
        "cat": str(tmp / "c.toml"),
        "obj": str(tmp / "box.obj"),
        "camp": str(camp / "campaign.csv"),
        "studies": str(Path(__file__).resolve().parents[1] / "examples" / "studies"),
    }


# (id, command line with {placeholders}, text the one error line must contain)
OUTPUT_CASES: list[tuple[str, list[str], str]] = [
    ("run-out-read-only", ["run", "{scn}", "-e", "housner", "--out", "{ro}/t.parquet"], "--out"),
    ("run-out-file-with-slash", ["run", "{scn}", "-e", "housner", "--out", "{tmp}/afile/"], "is a file"),
    ("run-out-under-a-file", ["run", "{scn}", "-e", "housner", "--out", "{tmp}/afile/sub/"], "is a file"),
    ("threshold-json-read-only", ["threshold", "{scn}", "-e", "housner", "--json", "{ro}/r.json"], "--json"),
    ("threshold-json-under-a-file", ["threshold", "{scn}", "-e", "housner", "--json", "{tmp}/afile/r.json"], "is a file"),
    ("rock-out-is-a-file", ["rock", "{obj}", "--out", "{tmp}/afile"], "--out"),
    ("rock-out-read-only", ["rock", "{obj}", "--out", "{ro}/rock"], "--out"),
    ("rock-scenario-exists", ["rock", "{obj}", "--out", "{tmp}/r", "--scenario", "{tmp}/old.toml"], "--overwrite"),
    ("rock-scenario-read-only", ["rock", "{obj}", "--out", "{tmp}/r", "--scenario", "{ro}/s.toml"], "--scenario"),
    ("rock-scenario-is-a-folder", ["rock", "{obj}", "--out", "{tmp}/r", "--scenario", "{tmp}/store"], "folder"),
    ("validate-out-is-a-file", ["validate", "{camp}", "--scenario", "{scn}", "-e", "housner", "--out", "{tmp}/afile"], "--out"),
    ("validate-out-read-only", ["validate", "{camp}", "--scenario", "{scn}", "-e", "housner", "--out", "{ro}/v"], "--out"),
    ("sweep-out-read-only", ["sweep", "{cat}", "{ro}/store"], "results store"),
    ("fragility-out-is-a-file", ["fragility", "{tmp}/store", "--out", "{tmp}/afile"], "--out"),
    ("fragility-out-read-only", ["fragility", "{tmp}/store", "--out", "{ro}/f"], "--out"),
    ("constrain-example-out-is-a-file", ["constrain", "--example", "--out", "{tmp}/afile"], "--out"),
    ("constrain-example-out-read-only", ["constrain", "--example", "--out", "{ro}/c"], "--out"),
    ("constrain-out-is-a-file", ["constrain", "{tmp}/old.toml", "--out", "{tmp}/afile"], "--out"),
    ("choose-out-read-only", ["choose", "{cat}", "--out", "{ro}/ch"], "--out"),
    ("report-out-is-a-file", ["report", "{studies}/housner.toml", "--out", "{tmp}/afile"], "is a file"),
    ("demo-out-read-only", ["demo", "--out", "{ro}"], "--out"),
]  # fmt: skip


@pytest.mark.parametrize(("args", "needle"), [c[1:] for c in OUTPUT_CASES], ids=[c[0] for c in OUTPUT_CASES])
def test_output_locations_checked_first(tmp_path: Path, args: list[str], needle: str) -> None:
    """A read-only location, a file where a folder goes (or the reverse), an existing file: one line, nothing written."""
    subs = _outputs_fixture(tmp_path)
    args = [a.format(**subs) for a in args]
    before = _snapshot(tmp_path)
    code, out, elapsed = _invoke(args)
    _check(code, out, needle, elapsed)
    assert _snapshot(tmp_path) == before  # nothing simulated, nothing written, the user's files untouched


def test_run_out_trailing_slash_is_a_folder(tmp_path: Path) -> None:
    """`run --out newdir/` (not existing) writes newdir/<name>.<engine>.parquet, not a file named newdir."""
    (tmp_path / "s.toml").write_text(BASE)
    code, out, _ = _work(["run", str(tmp_path / "s.toml"), "-e", "housner", "--out", f"{tmp_path}/newdir/"])
    assert code == 0, out
    assert (tmp_path / "newdir" / "block.housner.parquet").is_file()


def test_threshold_json_into_a_folder(tmp_path: Path) -> None:
    """`threshold --json DIR` writes DIR/<name>.<engine>.threshold.json (it used to fail after the search)."""
    import json

    (tmp_path / "s.toml").write_text(BASE)
    (tmp_path / "res").mkdir()
    code, out, _ = _work(
        [
            "threshold",
            str(tmp_path / "s.toml"),
            "-e",
            "housner",
            "--rel-tol",
            "0.01",
            "--json",
            str(tmp_path / "res"),
        ]
    )
    assert code == 0, out
    data = json.loads((tmp_path / "res" / "block.housner.threshold.json").read_text())
    assert data["param"] == "excitation.amplitude"


def test_rock_scenario_overwrite(tmp_path: Path) -> None:
    """`rock --scenario EXISTING.toml` replaces the file only with --overwrite (as `run --out` does)."""
    box_obj(tmp_path / "box.obj")
    old = tmp_path / "old.toml"
    old.write_text("# mine\n")
    args = ["rock", str(tmp_path / "box.obj"), "--out", str(tmp_path / "r"), "--scenario", str(old)]
    code, out, _ = _work([*args, "--overwrite"])
    assert code == 0, out
    assert "[rock]" in old.read_text() and "pbr-xval rock" in old.read_text()


# ------------------------------------------------------------------ rock: options, cut, multi-body, tiny clouds
ROCK_CASES: list[tuple[str, list[str], str]] = [
    ("grid-spacing-tiny", ["--grid-spacing", "1e-5"], "spacing"),
    ("grid-spacing-zero", ["--grid-spacing", "0"], "--grid-spacing"),
    ("grid-spacing-negative", ["--grid-spacing", "-0.01"], "--grid-spacing"),
    ("alpha-multiple-negative", ["--alpha-multiple", "-1"], "--alpha-multiple"),
    ("cut-z-nan", ["--cut-z", "nan"], "--cut-z"),
    ("cut-z-above-the-rock", ["--cut-z", "5"], "cut plane"),
    ("ten-point-cloud", ["{tmp}/ten.xyz"], "at least 100"),
]


@pytest.mark.parametrize(("args", "needle"), [c[1:] for c in ROCK_CASES], ids=[c[0] for c in ROCK_CASES])
def test_rock_cli(tmp_path: Path, args: list[str], needle: str) -> None:
    box_obj(tmp_path / "box.obj")
    rng = __import__("numpy").random.default_rng(1)
    (tmp_path / "ten.xyz").write_text("\n".join(" ".join(f"{c:.4f}" for c in p) for p in rng.random((10, 3))))
    args = [a.replace("{tmp}", str(tmp_path)) for a in args]
    scan = args.pop(0) if args and not args[0].startswith("-") else str(tmp_path / "box.obj")
    code, out, elapsed = _invoke(["rock", scan, "--out", str(tmp_path / "r"), *args])
    _check(code, out, needle, elapsed)
    assert not (tmp_path / "r").exists()


def test_rock_grid_spacing_tiny_subprocess(tmp_path: Path) -> None:
    """`--grid-spacing 1e-5` used to allocate 47.7 GiB (MemoryError); a real process answers in one line."""
    box_obj(tmp_path / "box.obj")
    code, out, elapsed = _cli("rock", "box.obj", "--grid-spacing", "1e-5", "--out", "r", cwd=tmp_path)
    assert code not in (-9, 124, 137), f"killed after {elapsed:.1f} s:\n{out}"
    _check(code, out, "at least", elapsed)
    assert not (tmp_path / "r").exists()


def test_rock_cut_without_networkx(tmp_path: Path) -> None:
    """`rock --cut-z` splits one scan into rock and pedestal without networkx (not a dependency)."""
    import json

    box_obj(tmp_path / "box.obj")  # 0.4 × 0.4 × 1.2 m
    code, out, _ = _work(["rock", str(tmp_path / "box.obj"), "--cut-z", "0.3", "--out", str(tmp_path / "r")])
    assert code == 0, out
    d = json.loads((tmp_path / "r" / "rock.json").read_text())
    assert d["volume_m3"] == pytest.approx(0.4 * 0.4 * 0.9, rel=1e-9)  # the part above the cut
    assert d["com_height_m"] == pytest.approx(0.45, rel=1e-9)


def test_rock_two_bodies_models_the_largest_with_a_warning(tmp_path: Path) -> None:
    """A scan of two disjoint bodies: a warning names them, and the largest is modelled (here and in scenarios)."""
    import json

    from pbr_xval.scenario import load_scenario
    from pbr_xval.scene import compile_scene

    _two_boxes_obj(tmp_path / "two.obj")
    code, out, _ = _work(
        [
            "rock",
            str(tmp_path / "two.obj"),
            "--out",
            str(tmp_path / "r"),
            "--scenario",
            str(tmp_path / "two.toml"),
        ]
    )
    assert code == 0, out
    warn = [ln for ln in out.splitlines() if ln.startswith("warning:")]
    assert len(warn) == 1 and "2 disjoint bodies" in warn[0] and "0.192" in warn[0], out
    d = json.loads((tmp_path / "r" / "rock.json").read_text())
    assert d["volume_m3"] == pytest.approx(0.192, rel=1e-9)  # the 0.4 × 0.4 × 1.2 box, not 0.192 + 0.008
    scene = compile_scene(load_scenario(tmp_path / "two.toml"))
    assert scene.info()["mass_kg"] == pytest.approx(0.192 * 2700.0, rel=1e-6)


# ------------------------------------------------------------------ validate
def _campaign(tmp: Path, *, rate_hz: float = 200.0, pga: str | None = None) -> Path:
    """Three one-column records (m/s²) and a campaign CSV; or, with ``pga``, the shared format with that pga_g."""
    import numpy as np

    t = np.arange(0.0, 2.0, 1.0 / rate_hz)
    motions = {f"m{i}": (0.5 + 0.5 * i) * np.sin(2 * np.pi * 2.0 * t) for i in (1, 2, 3)}
    d = tmp / "camp"
    d.mkdir(exist_ok=True)
    if pga is None:
        rows = ["test,motion_file,units,dt,toppled,motion"]
        for i, (name, acc) in enumerate(motions.items(), 1):
            (d / f"{name}.txt").write_text("\n".join(f"{x:.6e}" for x in acc) + "\n")
            rows.append(f"{i},{name}.txt,m/s2,{1.0 / rate_hz!r},0,{name}")
        (d / "campaign.csv").write_text("\n".join(rows) + "\n")
        return d / "campaign.csv"
    rows = ["test,motion,pga_g,pgv_over_pga_s,toppled_specimen1"]
    arrays = {}
    for i, acc in enumerate(motions.values(), 1):
        rows.append(f"{i},REC{i},{pga if i == 2 else '0.1'},0.05,0")
        arrays[f"test{i:03d}_acc_g"] = (acc / 9.80665).astype(np.float32)
        arrays[f"test{i:03d}_dt_s"] = np.float64(1.0 / rate_hz)
    (d / "experiments.csv").write_text("\n".join(rows) + "\n")
    np.savez(d / "table_motions.npz", **arrays)
    return d


VALIDATE_SCENARIO = """\
name = "box_validation"
duration = 3.0
settle_time = 0.0

[rock]
shape = "box"
half_extents = [0.1, 0.1, 0.4]
density = 2500.0

[contact]
friction_static = 1.0

[excitation]
type = "none"
"""

# (id, campaign kind: csv | shared800 | shared-neg, extra args, scenario text or None, needle)
VALIDATE_CASES: list[tuple[str, str, list[str], str | None, str]] = [
    ("tests-empty", "csv", ["--tests", ""], None, "--tests"),
    ("tests-only-commas", "csv", ["--tests", " , ,"], None, "--tests"),
    ("folds-zero", "csv", ["--folds", "0"], None, "--folds"),
    ("folds-negative", "csv", ["--folds", "-3"], None, "--folds"),
    ("folds-one", "csv", ["--folds", "1"], None, "--folds"),
    ("chunk-size-zero", "csv", ["--chunk-size", "0"], None, "--chunk-size"),
    ("chunk-size-negative", "csv", ["--chunk-size", "-2"], None, "--chunk-size"),
    ("workers-negative", "csv", ["--workers", "-3"], None, "--workers"),
    ("workers-zero", "csv", ["--workers", "0"], None, "--workers"),
    ("limit-zero", "csv", ["--limit", "0"], None, "--limit"),
    ("highpass-above-nyquist", "csv", ["--highpass", "150", "--lowpass", "0"], None, "Nyquist"),
    ("highpass-above-lowpass", "csv", ["--highpass", "500"], None, "--highpass"),
    ("highpass-nan", "csv", ["--highpass", "nan"], None, "--highpass"),
    ("lowpass-above-nyquist", "csv", ["--lowpass", "1000"], None, "--lowpass"),
    ("highpass-above-resampled-nyquist", "shared800", ["--highpass", "150", "--lowpass", "0"], None, "--resample"),
    ("pga-negative", "shared-neg", [], None, "pga_g"),
    ("sheet-without-pga", "csv", ["--baseline-source", "sheet"], None, "pga_g"),
    ("set-unknown-key", "csv", ["--set", "rtoll=1"], None, "rtoll"),
    ("set-bad-value", "csv", ["--set", "rtol=-1"], None, "rtol"),
    (
        "scenario-mesh-garbage",
        "csv",
        [],
        VALIDATE_SCENARIO.replace('shape = "box"\nhalf_extents = [0.1, 0.1, 0.4]', 'shape = "mesh"\npath = "garbage.obj"'),
        "garbage.obj",
    ),
]  # fmt: skip


@pytest.mark.parametrize(
    ("kind", "args", "text", "needle"), [c[1:] for c in VALIDATE_CASES], ids=[c[0] for c in VALIDATE_CASES]
)
def test_validate_cli(tmp_path: Path, kind: str, args: list[str], text: str | None, needle: str) -> None:
    camp = _campaign(
        tmp_path, rate_hz=800.0 if kind.startswith("shared") else 200.0, pga="-0.1" if kind == "shared-neg" else None
    ) if kind != "shared800" else _campaign(tmp_path, rate_hz=800.0, pga="0.1")  # fmt: skip
    (tmp_path / "s.toml").write_text(text or VALIDATE_SCENARIO)
    (tmp_path / "garbage.obj").write_text("not a mesh\n")
    out = tmp_path / "report"
    cmd = [
        "validate",
        str(camp),
        "--scenario",
        str(tmp_path / "s.toml"),
        "-e",
        "housner",
        "--out",
        str(out),
        *args,
    ]
    code, output, elapsed = _invoke(cmd)
    _check(code, output, needle, elapsed)
    assert not out.exists()  # nothing simulated, no report with F1 = nan


def test_validate_says_which_ims_the_rules_use(tmp_path: Path) -> None:
    """A campaign without pga_g: stdout says the rules use the records' IMs (it was noted only in validation.json)."""
    camp = _campaign(tmp_path)
    (tmp_path / "s.toml").write_text(VALIDATE_SCENARIO)
    code, out, _ = _work(
        ["validate", str(camp), "--scenario", str(tmp_path / "s.toml"), "-e", "housner", "--out",
         str(tmp_path / "rep"), "--limit", "1", "--workers", "1"]
    )  # fmt: skip
    assert code == 0, out
    assert "threshold rules: the corrected records' PGA and PGV/PGA" in out


# ------------------------------------------------------------------ sweep and fragility
NAN_OBJ = "v 0 0 0\nv 1 0 0\nv 0 1 nan\nv 0 0 1\nf 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\n"
MESH_CATALOG = CATALOG.replace(
    'shape = "box"\nhalf_extents = [0.2, 0.2, 0.6]', 'shape = "mesh"\npath = "MESH"'
)


@pytest.mark.parametrize(
    ("mesh", "text"), [("garbage.obj", "not a mesh\n"), ("nan.obj", NAN_OBJ)], ids=["garbage", "nan"]
)
def test_sweep_refuses_a_bad_catalog_mesh(tmp_path: Path, mesh: str, text: str) -> None:
    """A garbage or NaN mesh in the catalog: one line naming the rock and the file, not "1 done, 0 failed"."""
    (tmp_path / mesh).write_text(text)
    (tmp_path / "c.toml").write_text(MESH_CATALOG.replace("MESH", mesh))
    code, out, elapsed = _invoke(
        ["sweep", str(tmp_path / "c.toml"), str(tmp_path / "store"), "--executor", "inline"]
    )
    _check(code, out, mesh, elapsed)
    assert "rock" in _error_lines(out)[0] and not (tmp_path / "store").exists()


@pytest.fixture(scope="module")
def finished_store(tmp_path_factory: pytest.TempPathFactory) -> Path:
    tmp = tmp_path_factory.mktemp("store")
    (tmp / "c.toml").write_text(CATALOG)
    with within(120):
        res = CliRunner().invoke(
            app, ["sweep", str(tmp / "c.toml"), str(tmp / "store"), "--executor", "inline"]
        )
    assert res.exit_code == 0, res.output
    return tmp / "store"


def _chunk(store: Path) -> Path:
    (f,) = [p for p in store.rglob("*.parquet") if not p.name.startswith(".")]
    return f


def test_fragility_store_with_only_failed_rows(tmp_path: Path, finished_store: Path) -> None:
    import shutil

    import pyarrow as pa
    import pyarrow.parquet as pq

    store = tmp_path / "store"
    shutil.copytree(finished_store, store)
    f = _chunk(store)
    t = pq.read_table(f)
    i = t.schema.get_field_index("status")
    t = t.set_column(i, "status", pa.array(["error"] * len(t), type=t.schema.field("status").type))
    pq.write_table(t, f)
    code, out, elapsed = _invoke(["fragility", str(store), "--out", str(tmp_path / "fr")])
    _check(code, out, "none of its 2 simulation rows succeeded", elapsed)
    assert not (tmp_path / "fr").exists()


def test_fragility_truncated_chunk(tmp_path: Path, finished_store: Path) -> None:
    import shutil

    store = tmp_path / "store"
    shutil.copytree(finished_store, store)
    f = _chunk(store)
    f.write_bytes(f.read_bytes()[: f.stat().st_size // 2])
    code, out, elapsed = _invoke(["fragility", str(store), "--out", str(tmp_path / "fr")])
    _check(code, out, f.name, elapsed)
    assert "not a readable Parquet chunk" in out and not (tmp_path / "fr").exists()


# ------------------------------------------------------------------ threshold, records, constrain
RECORD_EXCITATION = '[excitation]\ntype = "record"\npath = "rec.txt"\ndt = 0.01\nunits = "g"\n\n'


def test_threshold_param_unset(tmp_path: Path) -> None:
    """`--param excitation.target_pga` when the scenario leaves it unset: one line, not a TypeError."""
    text = edit(BASE, BASE[BASE.index("[excitation]") : BASE.index("[toppling]")], RECORD_EXCITATION)
    (tmp_path / "s.toml").write_text(text)
    (tmp_path / "rec.txt").write_text("\n".join(f"{0.1 * math.sin(i / 5):.5f}" for i in range(200)) + "\n")
    code, out, elapsed = _invoke(
        ["threshold", str(tmp_path / "s.toml"), "-e", "housner", "--param", "excitation.target_pga"]
    )
    _check(code, out, "excitation.target_pga", elapsed)
    assert "unset" in out


def test_non_uniform_time_column_line_and_plain_floats(tmp_path: Path) -> None:
    """The line of the first irregular step (not the first data row), and plain numbers (no np.float64(...))."""
    exc = '[excitation]\ntype = "record"\npath = "nu.txt"\nunits = "g"\ntime_column = "time_s"\ncolumn = "acc_g"\n\n'
    (tmp_path / "s.toml").write_text(
        edit(BASE, BASE[BASE.index("[excitation]") : BASE.index("[toppling]")], exc)
    )
    rows = [(0.0, 0.1), (0.01, 0.2), (0.02, 0.1), (0.05, 0.0), (0.06, 0.1), (0.07, 0.2), (0.08, 0.1)]
    (tmp_path / "nu.txt").write_text("time_s acc_g\n" + "\n".join(f"{t} {a}" for t, a in rows) + "\n")
    code, out, elapsed = _invoke(
        ["run", str(tmp_path / "s.toml"), "-e", "housner", "--out", str(tmp_path / "t.parquet")]
    )
    _check(code, out, "line 5", elapsed)  # header on line 1: t = 0.05 is on line 5
    line = _error_lines(out)[0]
    assert "t=0.05 s after t=0.02 s" in line and "np.float64" not in line and "dt=0.01 s" in line
    assert not (tmp_path / "t.parquet").exists()


def test_constrain_weights_not_summing_to_one(tmp_path: Path) -> None:
    """Branch weights 5.0 and 0.5 are refused (they used to be rescaled silently) unless normalize_weights = true."""
    from pbr_xval.hazard.example import write_example

    cfg = write_example(tmp_path / "ex")
    text = cfg.read_text()
    head, rocks = text[: text.index("[[hazard.branch]]")], text[text.index("[[rock]]") :]
    branches = "".join(
        f'[[hazard.branch]]\nfile = "hazard/hazard_curve-rlz-00{i}-PGA_0.csv"\nweight = {w}\nname = "b{i}"\n\n'
        for i, w in ((0, 5.0), (1, 0.5))
    )
    bad = cfg.with_name("weights.toml")
    bad.write_text(head + branches + rocks)
    code, out, elapsed = _invoke(["constrain", str(bad), "--out", str(tmp_path / "rep")])
    _check(code, out, "weights", elapsed)
    assert "normalize_weights" in out and "5.5" in out and not (tmp_path / "rep").exists()


def test_issue_21_case_count() -> None:
    """Issue 21 found 43 bad cases among 171; each has at least one test here."""
    n = len(OUTPUT_CASES) + len(ROCK_CASES) + len(VALIDATE_CASES) + 2 + 2 + 3 + 3 + 3
    assert n >= 43, n


# ------------------------------------------------------------------ issue 21 leftovers: outputs that were replaced silently
def _box_cloud(path: Path, n: int = 3000) -> None:
    """A point cloud (x y z, m) sampled on the surface of the 0.4 × 0.4 × 1.2 m box resting on z = 0."""
    import numpy as np

    rng = np.random.default_rng(0)
    p = np.column_stack([rng.uniform(-0.2, 0.2, n), rng.uniform(-0.2, 0.2, n), rng.uniform(0.0, 1.2, n)])
    side = rng.integers(0, 6, n)
    for k, (axis, value) in enumerate([(0, -0.2), (0, 0.2), (1, -0.2), (1, 0.2), (2, 0.0), (2, 1.2)]):
        p[side == k, axis] = value
    np.savetxt(path, p, fmt="%.5f")


def _cloud_ply(path: Path, n: int = 3000) -> None:
    """The same cloud as an ASCII PLY with vertices only (a PLY scan that is not a mesh)."""
    xyz = path.with_suffix(".xyz")
    _box_cloud(xyz, n)
    rows = xyz.read_text().splitlines()
    xyz.unlink()
    header = ["ply", "format ascii 1.0", f"element vertex {len(rows)}", "property float x",
              "property float y", "property float z", "end_header"]  # fmt: skip
    path.write_text("\n".join(header + rows) + "\n")


LEFTOVER_CASES: list[tuple[str, list[str], str]] = [
    ("threshold-json-exists", ["threshold", "{scn}", "-e", "housner", "--json", "{tmp}/afile"], "--overwrite"),
    ("threshold-json-dir-default-exists", ["threshold", "{scn}", "-e", "housner", "--json", "{tmp}/res"], "--overwrite"),
    ("rock-cloud-surface-exists", ["rock", "{cloud}", "--out", "{tmp}/r", "--scenario", "{tmp}/new.toml"], "--overwrite"),
    ("rock-ply-cloud-surface-exists", ["rock", "{ply}", "--out", "{tmp}/r", "--scenario", "{tmp}/new.toml"], "--overwrite"),
    ("rock-cloud-surface-is-a-folder", ["rock", "{cloud}", "--out", "{tmp}/r", "--scenario", "{tmp}/dir.toml"], "folder"),
]  # fmt: skip


@pytest.mark.parametrize(
    ("args", "needle"), [c[1:] for c in LEFTOVER_CASES], ids=[c[0] for c in LEFTOVER_CASES]
)
def test_existing_outputs_need_overwrite(tmp_path: Path, args: list[str], needle: str) -> None:
    """`threshold --json EXISTING` and the `<stem>.rock.obj` a point cloud's `rock --scenario` writes beside the
    scenario: refused without --overwrite (as every other output), in one line, before any work, nothing written."""
    subs = _outputs_fixture(tmp_path)
    (tmp_path / "res").mkdir()
    (tmp_path / "res" / "block.housner.threshold.json").write_text('{"mine": true}')
    _box_cloud(tmp_path / "cloud.xyz")
    _cloud_ply(tmp_path / "cloud.ply")
    (tmp_path / "new.rock.obj").write_text("# the user's own mesh\n")
    (tmp_path / "dir.rock.obj").mkdir()
    subs.update(cloud=str(tmp_path / "cloud.xyz"), ply=str(tmp_path / "cloud.ply"))
    before = _snapshot(tmp_path)
    code, out, elapsed = _invoke([a.format(**subs) for a in args])
    _check(code, out, needle, elapsed)
    assert _snapshot(tmp_path) == before


def test_threshold_json_overwrite(tmp_path: Path) -> None:
    """`threshold --json EXISTING --overwrite` replaces the file with the result."""
    import json

    (tmp_path / "s.toml").write_text(BASE)
    old = tmp_path / "r.json"
    old.write_text('{"mine": true}')
    args = ["threshold", str(tmp_path / "s.toml"), "-e", "housner", "--rel-tol", "0.01", "--json", str(old)]
    code, out, _ = _work([*args, "--overwrite"])
    assert code == 0, out
    assert json.loads(old.read_text())["param"] == "excitation.amplitude"


def test_rock_cloud_scenario_overwrite(tmp_path: Path) -> None:
    """A point cloud's `rock --scenario S.toml --overwrite` replaces S.rock.obj with the reconstructed surface,
    which the scenario names; a mesh scan writes no S.rock.obj (a user's file of that name is left alone)."""
    _box_cloud(tmp_path / "cloud.xyz")
    (tmp_path / "s.rock.obj").write_text("# the user's own mesh\n")
    args = [
        "rock",
        str(tmp_path / "cloud.xyz"),
        "--out",
        str(tmp_path / "r"),
        "--scenario",
        str(tmp_path / "s.toml"),
    ]
    code, out, _ = _work([*args, "--overwrite"])
    assert code == 0, out
    assert (tmp_path / "s.rock.obj").read_text().lstrip().startswith(("v ", "#"))
    assert "the user's own mesh" not in (tmp_path / "s.rock.obj").read_text()
    assert 'path = "s.rock.obj"' in (tmp_path / "s.toml").read_text()
    box_obj(tmp_path / "box.obj")
    (tmp_path / "m.rock.obj").write_text("# the user's own mesh\n")
    args = [
        "rock",
        str(tmp_path / "box.obj"),
        "--out",
        str(tmp_path / "r2"),
        "--scenario",
        str(tmp_path / "m.toml"),
    ]
    code, out, _ = _work(args)
    assert code == 0, out
    assert (tmp_path / "m.rock.obj").read_text() == "# the user's own mesh\n"
