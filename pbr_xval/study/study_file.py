"""Study files: which scenarios, which engines, which studies — validated up front, run in one go.

A study file is TOML::

    name = "housner"                       # report folder name: reports/<name>/
    title = "Housner block: thresholds and histories"
    scenario = "../housner_halfsine.toml"  # relative to the study file
    engines = "all"                        # or a list, e.g. ["housner", "mujoco"]

    [[study]]
    type = "thresholds"                    # a key of STUDY_MODULES
    # ... that study's own options (validated by its Config model)

    [[study]]
    type = "histories"
    engines = ["housner", "mujoco"]        # optional: this study's engines
    quick = { }                            # optional: option overrides used with --quick

Several scenarios are given as ``[[scenarios]]`` tables, each with a ``label`` and either a
``path`` (a scenario file) or a ``synthetic`` table: a rock generated at run time by
:func:`pbr_xval.geometry.synthetic.synthetic_rock` (deterministic for a seed) and put into the
scenario named by ``base`` in place of its rock::

    [[scenarios]]
    label = "synthetic"
    base = "../housner_halfsine.toml"
    synthetic = { seed = 7, target_alpha_deg = 15.0, density = 2600.0 }

A study table may name its scenarios (``scenario = "housner"`` or ``scenarios = [...]``,
labels); by default it runs on every scenario. Study-level keys the runner consumes
(``scenario``, ``scenarios``, ``engines``, ``title``, ``quick``) are taken out before the rest
is validated by the study module's ``Config`` model.

``engines = "all"`` means every registered engine that imports; engines whose capabilities do
not include the scenario's rock shape are skipped with a note (the studies themselves skip
engines that raise :class:`~pbr_xval.engine.NotApplicable`).

Errors are :class:`StudyFileError` naming the file and the key, like
:class:`~pbr_xval.scenario.ScenarioError`.
"""

from __future__ import annotations

import importlib
import time
import traceback
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ValidationError

from pbr_xval.geometry.synthetic import SYNTHETIC_ROCK_KEYS
from pbr_xval.jsonio import jsonable
from pbr_xval.scenario import Scenario, ScenarioError, load_scenario, scenario_from_dict
from pbr_xval.status import RunStatus
from pbr_xval.study.base import StudyResult
from pbr_xval.tomlio import read_toml, validation_lines

__all__ = [
    "STUDY_MODULES",
    "ScenarioEntry",
    "StudyEntry",
    "StudyFileError",
    "StudySpec",
    "load_study_spec",
    "run_study",
    "study_config_class",
]

#: study ``type`` -> module exposing ``<X>Config`` and ``run(config, scenario, engines, *, progress)``
STUDY_MODULES: dict[str, str] = {
    "thresholds": "pbr_xval.study.thresholds",
    "histories": "pbr_xval.study.histories",
    "fragility": "pbr_xval.study.fragility_map",
    "tradeoff": "pbr_xval.study.tradeoff",
    "extremes": "pbr_xval.study.extremes",
    "azimuth": "pbr_xval.study.azimuth",
}

#: keys of a ``[[study]]`` table consumed by the runner, not by the study's Config
RUNNER_KEYS = ("scenario", "scenarios", "engines", "title", "quick")

SYNTHETIC_KEYS = {*SYNTHETIC_ROCK_KEYS, "density"}


class StudyFileError(ValueError):
    """A study file is invalid; the message names the file, the key and what was expected."""


# ------------------------------------------------------------------ model
@dataclass
class ScenarioEntry:
    """One scenario of a study file: loaded now (``path``) or generated at run time (``synthetic``)."""

    label: str
    path: Path | None = None
    base: Path | None = None
    synthetic: dict[str, Any] | None = None
    scenario: Scenario | None = None  # loaded (path) or materialised (synthetic)

    @property
    def generated(self) -> bool:
        return self.synthetic is not None


@dataclass
class StudyEntry:
    """One ``[[study]]`` table, validated."""

    index: int
    type: str
    config: BaseModel
    options: dict[str, Any]
    quick: dict[str, Any]
    scenarios: list[str]
    engines: list[str] | None
    title: str | None = None


@dataclass
class StudySpec:
    """A validated study file."""

    name: str
    title: str
    source: Path | None
    scenarios: list[ScenarioEntry]
    engines: list[str]
    engines_all: bool
    studies: list[StudyEntry]
    description: str = ""
    #: files generated at run time (synthetic meshes and their scenario files): name -> path
    assets: dict[str, Path] = field(default_factory=dict)
    #: notes from resolving engines ("all": which failed to import)
    notes: list[str] = field(default_factory=list)
    interrupted: bool = False

    def scenario(self, label: str) -> Scenario:
        for s in self.scenarios:
            if s.label == label:
                if s.scenario is None:
                    raise StudyFileError(
                        f"scenario {label!r} is generated at run time; call materialise() first"
                    )
                return s.scenario
        raise KeyError(label)

    def materialise(self, work_dir: Path) -> None:
        """Generate the synthetic scenarios into ``work_dir`` (deterministic; records ``assets``)."""
        work_dir = Path(work_dir)
        for s in self.scenarios:
            if s.generated and s.scenario is None:
                s.scenario = _materialise_synthetic(s, work_dir, self.source)
                for p in sorted(work_dir.glob(f"{s.label}.*")):
                    self.assets[p.name] = p


def _where(source: Path | None) -> str:
    return str(source) if source else "<study>"


def _err(source: Path | None, key: str, msg: str) -> StudyFileError:
    return StudyFileError(f"{_where(source)}: key '{key}': {msg}")


def study_config_class(kind: str) -> type[BaseModel]:
    """The ``Config`` model of study ``kind`` (imports its module lazily)."""
    mod = importlib.import_module(STUDY_MODULES[kind])
    classes = [
        v
        for k, v in vars(mod).items()
        if k.endswith("Config")
        and isinstance(v, type)
        and issubclass(v, BaseModel)
        and "type" in v.model_fields
    ]
    if not classes:
        raise ImportError(f"{STUDY_MODULES[kind]} defines no <X>Config model with a 'type' field")
    # prefer the one whose name matches the kind
    for c in classes:
        if c.__name__.lower().startswith(kind.rstrip("s").lower()):
            return c
    return classes[0]


def _study_run(kind: str) -> Callable[..., StudyResult]:
    return importlib.import_module(STUDY_MODULES[kind]).run


def _format_validation(exc: ValidationError, source: Path | None, prefix: str) -> str:
    return "\n".join(validation_lines(exc, _where(source), prefix=prefix))


def _available_engines() -> tuple[list[str], list[str]]:
    from pbr_xval.engine import EngineNotAvailable, get_engine, registered_names

    ok, notes = [], []
    for name in registered_names():
        try:
            get_engine(name)
            ok.append(name)
        except EngineNotAvailable as exc:
            notes.append(f"engine {name!r} skipped: not available ({exc})")
        except Exception as exc:  # a broken plugin must not kill a study
            notes.append(f"engine {name!r} skipped: failed to import ({type(exc).__name__}: {exc})")
    return ok, notes


def _engines_value(value: Any, source: Path | None, key: str) -> tuple[list[str], bool]:
    if value == "all":
        return [], True
    if isinstance(value, list) and value and all(isinstance(v, str) and v for v in value):
        if len(set(value)) != len(value):
            raise _err(source, key, f"duplicate engine names (found {value!r})")
        return list(value), False
    raise _err(source, key, f'expected "all" or a non-empty list of engine names (found {value!r})')


def _load_scenario_entry(raw: Any, key: str, source: Path | None, base_dir: Path) -> ScenarioEntry:
    if not isinstance(raw, dict):
        raise _err(source, key, f"expected a table with 'label' and 'path' or 'synthetic' (found {raw!r})")
    extra = set(raw) - {"label", "path", "base", "synthetic"}
    if extra:
        raise _err(
            source, f"{key}.{sorted(extra)[0]}", "unknown key; expected one of: base, label, path, synthetic"
        )
    label = raw.get("label")
    if not isinstance(label, str) or not label.replace("_", "").replace("-", "").isalnum():
        raise _err(
            source, f"{key}.label", f"expected a short name (letters, digits, _ or -) (found {label!r})"
        )
    if ("path" in raw) == ("synthetic" in raw):
        raise _err(source, key, "give either 'path' (a scenario file) or 'synthetic' (a generated rock)")
    if "path" in raw:
        if not isinstance(raw["path"], str):
            raise _err(source, f"{key}.path", f"expected a file path (found {raw['path']!r})")
        p = base_dir / raw["path"]
        try:
            scn = load_scenario(p)
        except ScenarioError as exc:
            raise StudyFileError(f"{_where(source)}: key '{key}.path': invalid scenario:\n{exc}") from None
        return ScenarioEntry(label=label, path=p, scenario=scn)
    syn = raw["synthetic"]
    if not isinstance(syn, dict):
        raise _err(source, f"{key}.synthetic", f"expected a table of synthetic_rock options (found {syn!r})")
    bad = set(syn) - SYNTHETIC_KEYS
    if bad:
        raise _err(
            source,
            f"{key}.synthetic.{sorted(bad)[0]}",
            f"unknown key; expected one of: {', '.join(sorted(SYNTHETIC_KEYS))}",
        )
    if not isinstance(syn.get("seed", 0), int):
        raise _err(source, f"{key}.synthetic.seed", f"expected an integer (found {syn.get('seed')!r})")
    if "base" not in raw or not isinstance(raw["base"], str):
        raise _err(
            source,
            f"{key}.base",
            "a synthetic scenario needs 'base': the scenario file whose rock it replaces",
        )
    bp = base_dir / raw["base"]
    try:
        load_scenario(bp)
    except ScenarioError as exc:
        raise StudyFileError(f"{_where(source)}: key '{key}.base': invalid scenario:\n{exc}") from None
    return ScenarioEntry(label=label, base=bp, synthetic=dict(syn))


def _materialise_synthetic(entry: ScenarioEntry, work_dir: Path, source: Path | None) -> Scenario:
    """Write ``<label>.obj`` and ``<label>.toml`` into ``work_dir`` and load the scenario."""
    from pbr_xval.geometry.synthetic import synthetic_rock

    work_dir.mkdir(parents=True, exist_ok=True)
    opts = dict(entry.synthetic or {})
    density = float(opts.pop("density", 2600.0))
    if "radii" in opts:
        opts["radii"] = tuple(opts["radii"])
    mesh, info = synthetic_rock(**opts)
    mesh_path = work_dir / f"{entry.label}.obj"
    mesh.export(mesh_path)
    assert entry.base is not None
    base = load_scenario(entry.base)
    data = base.model_dump(mode="json", exclude_unset=True)
    data["name"] = f"{base.name}_{entry.label}"
    data["description"] = (
        f"{base.description} — rock replaced by pbr_xval.geometry.synthetic.synthetic_rock"
        f"({', '.join(f'{k}={v!r}' for k, v in sorted((entry.synthetic or {}).items()))})"
    )
    data["rock"] = {"shape": "mesh", "path": mesh_path.name, "density": density}
    scn_path = work_dir / f"{entry.label}.toml"
    scn = scenario_from_dict(data, source=scn_path)
    scn_path.write_text(
        f"# generated by pbr-xval from {entry.base.name} and synthetic_rock options "
        f"{entry.synthetic!r}\n# {info!r}\n" + scn.to_toml()
    )
    return load_scenario(scn_path)


def load_study_spec(path: str | Path, *, quick: bool = False) -> StudySpec:
    """Read and validate a study file; every study table is validated by its module's Config.

    ``quick`` merges each study's ``quick`` table over its options.

    Raises
    ------
    StudyFileError
        naming the file and the key.
    """
    source = Path(path)
    data = read_toml(
        source, what="study", expected="name, [[scenario]] and [[study]] tables", error=StudyFileError
    )
    return study_spec_from_dict(data, source=source, quick=quick)


def study_spec_from_dict(
    data: dict[str, Any], *, source: Path | None = None, quick: bool = False
) -> StudySpec:
    """Validate a parsed study file (see :func:`load_study_spec`)."""
    known = {"name", "title", "description", "scenario", "scenarios", "engines", "study"}
    for k in data:
        if k not in known:
            raise _err(source, k, f"unknown key; expected one of: {', '.join(sorted(known))}")
    base_dir = Path(source).resolve().parent if source else Path.cwd()
    name = data.get("name")
    if not isinstance(name, str) or not name or not all(c.isalnum() or c in "_-." for c in name):
        raise _err(source, "name", f"expected a folder-safe name (letters, digits, _ - .) (found {name!r})")
    title = data.get("title", name)
    if not isinstance(title, str):
        raise _err(source, "title", f"expected a string (found {title!r})")
    description = data.get("description", "")
    if not isinstance(description, str):
        raise _err(source, "description", f"expected a string (found {description!r})")

    # scenarios
    if ("scenario" in data) == ("scenarios" in data):
        raise _err(
            source, "scenario", "give either 'scenario' (one file) or '[[scenarios]]' (several, with labels)"
        )
    entries: list[ScenarioEntry] = []
    if "scenario" in data:
        if not isinstance(data["scenario"], str):
            raise _err(source, "scenario", f"expected a scenario file path (found {data['scenario']!r})")
        p = base_dir / data["scenario"]
        try:
            scn = load_scenario(p)
        except ScenarioError as exc:
            raise StudyFileError(f"{_where(source)}: key 'scenario': invalid scenario:\n{exc}") from None
        entries.append(ScenarioEntry(label=scn.name, path=p, scenario=scn))
    else:
        raw = data["scenarios"]
        if not isinstance(raw, list) or not raw:
            raise _err(source, "scenarios", "expected a non-empty array of tables ([[scenarios]])")
        for i, r in enumerate(raw):
            entries.append(_load_scenario_entry(r, f"scenarios[{i}]", source, base_dir))
        labels = [e.label for e in entries]
        dup = {x for x in labels if labels.count(x) > 1}
        if dup:
            raise _err(source, "scenarios", f"duplicate labels {sorted(dup)}")
    labels = [e.label for e in entries]

    # engines
    engines, engines_all = _engines_value(data.get("engines", "all"), source, "engines")
    notes: list[str] = []
    if not engines_all:
        from pbr_xval.engine import registered_names

        reg = registered_names()
        unknown = [e for e in engines if e not in reg]
        if unknown:
            raise _err(
                source, "engines", f"unknown engine {unknown[0]!r}; registered engines: {', '.join(reg)}"
            )

    # studies
    raw_studies = data.get("study")
    if not isinstance(raw_studies, list) or not raw_studies:
        raise _err(source, "study", "expected at least one [[study]] table")
    studies: list[StudyEntry] = []
    for i, st in enumerate(raw_studies):
        key = f"study[{i}]"
        if not isinstance(st, dict):
            raise _err(source, key, "expected a table")
        kind = st.get("type")
        if kind not in STUDY_MODULES:
            raise _err(source, f"{key}.type", f"expected one of: {', '.join(STUDY_MODULES)} (found {kind!r})")
        opts = {k: v for k, v in st.items() if k not in RUNNER_KEYS}
        qk = st.get("quick", {})
        if not isinstance(qk, dict):
            raise _err(source, f"{key}.quick", f"expected a table of option overrides (found {qk!r})")
        if "scenario" in st and "scenarios" in st:
            raise _err(source, f"{key}.scenario", "give 'scenario' or 'scenarios', not both")
        sel = st.get("scenarios", st.get("scenario", labels))
        sel = [sel] if isinstance(sel, str) else sel
        if not isinstance(sel, list) or not all(isinstance(s, str) for s in sel):
            raise _err(source, f"{key}.scenarios", f"expected scenario labels (found {sel!r})")
        for s in sel:
            if s not in labels:
                raise _err(
                    source,
                    f"{key}.scenario",
                    f"unknown scenario label {s!r}; expected one of: {', '.join(labels)}",
                )
        st_engines = None
        if "engines" in st:
            st_engines, st_all = _engines_value(st["engines"], source, f"{key}.engines")
            if st_all:
                st_engines = None
        st_title = st.get("title")
        if st_title is not None and not isinstance(st_title, str):
            raise _err(source, f"{key}.title", f"expected a string (found {st_title!r})")
        try:
            cls = study_config_class(kind)
        except ImportError as exc:
            raise _err(
                source, f"{key}.type", f"study module {STUDY_MODULES[kind]} cannot be imported ({exc})"
            ) from None
        merged = {**opts, **qk} if quick else opts
        try:
            cfg = cls.model_validate(merged)
            if qk and not quick:  # validate the quick overrides as well, so --quick never fails late
                cls.model_validate({**opts, **qk})
        except ValidationError as exc:
            raise StudyFileError(_format_validation(exc, source, key)) from None
        studies.append(
            StudyEntry(
                index=i,
                type=kind,
                config=cfg,
                options=merged,
                quick=qk,
                scenarios=list(sel),
                engines=st_engines,
                title=st_title,
            )
        )
    return StudySpec(
        name=name,
        title=title,
        description=description,
        source=source,
        scenarios=entries,
        engines=engines,
        engines_all=engines_all,
        studies=studies,
        notes=notes,
    )


# ------------------------------------------------------------------ running
def _shape_filter(engines: Sequence[str], scn: Scenario) -> tuple[list[str], list[str]]:
    """Engines whose capabilities include the rock shape, and notes for those skipped."""
    from pbr_xval.engine import get_engine

    shape = scn.rock.shape
    keep, notes = [], []
    for name in engines:
        try:
            caps = get_engine(name).capabilities
        except Exception as exc:
            notes.append(f"engine {name!r} skipped: not available ({exc})")
            continue
        if shape not in caps.shapes:
            notes.append(f"engine {name!r} skipped: it does not model {shape!r} rocks (NotApplicable)")
            continue
        keep.append(name)
    return keep, notes


def failed_result(
    kind: str, title: str, exc: BaseException, *, scenario: Scenario | None = None
) -> StudyResult:
    """A StudyResult recording a study that raised (rendered as a failed section)."""
    tb = "".join(traceback.format_exception(type(exc), exc, exc.__traceback__))
    msg = f"{type(exc).__name__}: {exc}"
    prov: dict[str, Any] = {"status": RunStatus.FAILED, "error": msg, "traceback": tb}
    if scenario is not None:
        prov["scenario"] = {"name": scenario.name, "hash": scenario.content_hash()}
    return StudyResult(
        kind=kind,
        title=title,
        summary=[f"**FAILED**: {msg}"],
        headline={"status": RunStatus.FAILED},
        provenance=prov,
        notes=[f"the study raised {msg}; the other studies still ran"],
    )


def is_failed(result: StudyResult) -> bool:
    return result.provenance.get("status") in ("failed", "interrupted")


def run_study(
    spec: StudySpec,
    progress: Callable[[str, float], None] | bool | None = None,
    *,
    work_dir: Path | None = None,
    on_result: Callable[[StudyResult], None] | None = None,
    console: Any = None,
) -> list[StudyResult]:
    """Run every study of ``spec`` on its scenarios; one :class:`StudyResult` per (study, scenario).

    ``progress``: a callable ``(message, fraction_done_overall)``, or True for a rich
    progress bar with ETA (the default when None and the console is a terminal), or False.
    A study that raises is recorded as a failed section (:func:`failed_result`); the others
    still run. Ctrl-C stops the run: what was computed is returned, the rest is marked
    ``interrupted`` and ``spec.interrupted`` is set.
    """
    import tempfile

    if any(s.generated and s.scenario is None for s in spec.scenarios):
        if work_dir is None:
            work_dir = Path(tempfile.mkdtemp(prefix=f"pbr_xval_{spec.name}_"))
        spec.materialise(work_dir)

    if spec.engines_all:
        avail, notes = _available_engines()
        spec.engines = avail
        spec.notes = list(dict.fromkeys([*spec.notes, *notes]))

    jobs: list[tuple[StudyEntry, ScenarioEntry]] = [
        (st, next(e for e in spec.scenarios if e.label == lab)) for st in spec.studies for lab in st.scenarios
    ]
    multi = len(spec.scenarios) > 1

    bar = None
    if progress is None or progress is True:
        from pbr_xval.console import make_console

        console = make_console(console, stderr=True)
        if progress is True or console.is_terminal:
            from rich.progress import (
                BarColumn,
                Progress,
                TaskProgressColumn,
                TextColumn,
                TimeElapsedColumn,
                TimeRemainingColumn,
            )

            bar = Progress(
                TextColumn("[bold]{task.description}"),
                BarColumn(),
                TaskProgressColumn(),
                TimeElapsedColumn(),
                TextColumn("ETA"),
                TimeRemainingColumn(),
                console=console,
                transient=False,
            )
        progress = None
    cb = progress if callable(progress) else None

    results: list[StudyResult] = []
    n = len(jobs)

    def run_all(report: Callable[[str, float], None]) -> None:
        for j, (st, se) in enumerate(jobs):
            scn = se.scenario
            assert scn is not None
            base_title = st.title or _default_title(st.type)
            title = f"{base_title} — {se.label}" if multi else base_title
            engines = list(st.engines) if st.engines is not None else list(spec.engines)
            engines, notes = _shape_filter(engines, scn)
            report(f"{title}", j / n)
            t0 = time.perf_counter()
            try:
                run = _study_run(st.type)

                def sub(msg: str, frac: float, _j: int = j, _t: str = title) -> None:
                    frac = min(max(float(frac), 0.0), 1.0)
                    report(f"{_t}: {msg}", (_j + frac) / n)

                res = run(st.config, scn, engines, progress=sub)
            except KeyboardInterrupt:
                spec.interrupted = True
                for st2, se2 in jobs[j:]:
                    t2 = st2.title or _default_title(st2.type)
                    r = StudyResult(
                        kind=st2.type,
                        title=f"{t2} — {se2.label}" if multi else t2,
                        summary=["**INTERRUPTED**: not run (Ctrl-C)"],
                        headline={"status": RunStatus.INTERRUPTED},
                        provenance={"status": RunStatus.INTERRUPTED},
                    )
                    results.append(r)
                return
            except Exception as exc:
                res = failed_result(st.type, title, exc, scenario=scn)
            res.wall_time = res.wall_time or (time.perf_counter() - t0)
            if st.title:
                res.title = st.title
            if multi and se.label not in res.title:
                res.title = f"{res.title} — {se.label}"
            res.notes = [*notes, *res.notes]
            res.provenance.setdefault("study_type", st.type)
            res.provenance.setdefault("study_options", jsonable(st.options))
            res.provenance.setdefault("scenario_label", se.label)
            res.provenance.setdefault("scenario_hash", scn.content_hash())
            res.provenance.setdefault("scenario_name", scn.name)
            if se.path is not None:
                res.provenance.setdefault("scenario_file", str(se.path))
            results.append(res)
            if on_result is not None:
                on_result(res)
            report(f"{title}: done", (j + 1) / n)

    if bar is not None:
        with bar:
            task = bar.add_task(spec.name, total=1.0)

            def upd(msg: str, frac: float) -> None:
                bar.update(task, completed=frac, description=_short(msg))

            run_all(upd)
    else:
        run_all(cb or (lambda m, f: None))
    return results


def _short(msg: str, n: int = 70) -> str:
    return msg if len(msg) <= n else msg[: n - 1] + "…"


def _default_title(kind: str) -> str:
    return {
        "thresholds": "Toppling thresholds",
        "histories": "Rocking histories",
        "fragility": "Fragility maps",
        "tradeoff": "Speed–accuracy trade-off",
        "extremes": "Stability at the extremes",
        "azimuth": "Toppling level per shaking azimuth",
    }.get(kind, kind)
