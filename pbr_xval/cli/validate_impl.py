"""The plain function behind ``pbr-xval validate`` (exit codes: 0 done, 1 some runs failed, 2 bad input)."""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

__all__ = ["validate_command"]


def _check_options(
    scenario: Path | None, engines: list[str], ensemble: bool, baseline_source: str, tail: float,
    folds: int, workers: int, chunk_size: int, limit: int | None, tests: str | None,
    highpass: float, lowpass: float, resample: float,
) -> str | None:  # fmt: skip
    """What is wrong with the command's options, checked before anything is read; None if nothing."""
    if scenario is None:
        return "--scenario is required (the specimen's scenario TOML)"
    if not engines and not ensemble:
        return "give at least one --engine (e.g. --engine mujoco)"
    if baseline_source not in ("auto", "sheet", "record"):
        return f"--baseline-source {baseline_source!r}: expected auto, sheet or record"
    if not (tail >= 0):
        return f"--tail {tail!r}: expected a time >= 0 s"
    for opt, value, least in (
        ("--folds", folds, 2),
        ("--workers", workers, 1),
        ("--chunk-size", chunk_size, 1),
    ):
        if value < least:
            return f"{opt} {value}: expected an integer ≥ {least}"
    if limit is not None and limit < 1:
        return f"--limit {limit}: expected at least 1 test"
    if tests is not None and not [t for t in tests.split(",") if t.strip()]:
        return (
            f"--tests {tests!r}: names no test; expected comma-separated test identifiers (omit it for all)"
        )
    for opt, hz in (("--highpass", highpass), ("--lowpass", lowpass), ("--resample", resample)):
        if not (math.isfinite(hz) and hz >= 0):
            return f"{opt} {hz!r}: expected a frequency ≥ 0 Hz (0: none)"
    if highpass and lowpass and highpass >= lowpass:
        return (
            f"--highpass {highpass:g} Hz: not below --lowpass {lowpass:g} Hz; expected a band (0: no filter)"
        )
    return None


def _print_scores(res: Any, console: Any, ensemble: bool) -> None:
    """Each model's scores on the console, then the F1, ensemble and Brier lines on stdout."""
    from rich.markup import escape

    from pbr_xval.validation.campaign_report import brier_lines, f1_lines

    sc = res.scores
    for r in sc.itertuples():
        console.print(
            f"{r.model:>18s}  F1 {r.f1:.3f}  acc {r.accuracy:.3f}  prec {r.precision:.3f}  rec {r.recall:.3f}"
            f"  TP {r.tp} FP {r.fp} FN {r.fn} TN {r.tn}  {escape('[' + r.evaluated_on + ']')}",
            soft_wrap=True,
        )
    for line in f1_lines(res):
        print(line, flush=True)
    if ensemble:
        from pbr_xval.validation.ensemble import ensemble_lines

        for line in ensemble_lines(res):  # F1 ensemble (Brier ensemble is among the Brier lines)
            print(line, flush=True)
    for line in brier_lines(res):  # every model: engines (0/1), rules, logistic baselines
        print(line, flush=True)


def _meta(
    campaign: Path, camp: Any, specimen: int, scenario: Path, scn: Any, engines: list[str],
    settings: dict[str, Any], base: Any, tail: float, wall: float, summary: Any, ens_meta: dict[str, Any],
) -> dict[str, Any]:  # fmt: skip
    """What the report records about the run (inputs, settings, baseline correction, timing)."""
    return {
        "campaign": str(campaign),
        "campaign_form": camp.form,
        "specimen": specimen,
        "tests": len(camp),
        "records": len({t.motion for t in camp.tests}),
        "scenario": str(scenario),
        "scenario_hash": scn.content_hash(),
        "engines": ", ".join(engines),
        "engine_settings": settings,
        "baseline_correction": base.describe(),
        "tail_s": tail,
        "toppling": scn.toppling.model_dump(mode="json"),
        "wall_s": round(wall, 1),
        "chunks_run_skipped_failed": f"{summary.done}/{summary.skipped}/{summary.failed}",
        **ens_meta,
    }


def _print_inputs(
    console: Any, campaign: Path, camp: Any, specimen: int, baseline_source: str, has_sheet: bool
) -> None:
    """The campaign read, and (baseline source auto) where the threshold rules take PGA and PGV/PGA."""
    from rich.markup import escape

    console.print(
        f"campaign {escape(str(campaign))}: {len(camp)} tests of specimen {specimen} "
        f"({sum(t.toppled for t in camp.tests)} toppled), {len({t.motion for t in camp.tests})} records",
        soft_wrap=True,
    )
    if baseline_source == "auto":
        console.print(
            "threshold rules: "
            + (
                "the lab sheet's PGA and PGV/PGA (pga_g, pgv_over_pga_s of every test)"
                if has_sheet
                else "the corrected records' PGA and PGV/PGA (the campaign does not give pga_g and "
                "pgv_over_pga_s for every test; --baseline-source sheet would refuse it)"
            ),
            soft_wrap=True,
            highlight=False,
        )


def validate_command(
    campaign: Path,
    *,
    specimen: int,
    scenario: Path | None,
    engines: list[str],
    out: Path | None = None,
    tests: str | None = None,
    limit: int | None = None,
    folds: int = 4,
    highpass: float = 0.3,
    lowpass: float = 25.0,
    detrend: str = "linear",
    resample: float = 200.0,
    tail: float = 3.0,
    workers: int = 2,
    chunk_size: int = 1,
    baseline_source: str = "auto",
    sets: list[str] | None = None,
    console: Any = None,
    progress: bool = True,
    transfer: str | None = None,
    calibration: str | None = None,
    ensemble: bool = False,
    members: int | None = None,
    half_width: float | None = None,
    batch: int = 4,
) -> int:
    """Validate the inputs (campaign, scenario, engines) in full, run, score, write the report."""
    from rich.markup import escape

    from pbr_xval.atomic import check_output_dir
    from pbr_xval.cli._app import _parse_sets
    from pbr_xval.console import make_console
    from pbr_xval.engine import get_engine
    from pbr_xval.errors import OutputPathError
    from pbr_xval.scenario import ScenarioError, load_scenario
    from pbr_xval.validation.campaign import Baseline, CampaignError, load_campaign
    from pbr_xval.validation.campaign_report import evaluate, write_report
    from pbr_xval.validation.execution import run_campaign

    console = make_console(console)
    err = make_console(stderr=True)

    def fail(msg: str) -> int:
        err.print(f"[red]error:[/] {escape(msg)}", soft_wrap=True, highlight=False)
        return 2

    bad = _check_options(
        scenario, engines, ensemble, baseline_source, tail, folds, workers, chunk_size, limit, tests,
        highpass, lowpass, resample,
    )  # fmt: skip
    if bad:
        return fail(bad)
    assert scenario is not None
    try:
        base = Baseline(
            detrend=detrend,
            highpass_hz=highpass or None,
            lowpass_hz=lowpass or None,
            resample_hz=resample or None,
        )
        camp = load_campaign(campaign, specimen)
        selection = [t.strip() for t in tests.split(",") if t.strip()] if tests else None
        camp = camp.select(selection, limit)
    except CampaignError as exc:
        return fail(str(exc))
    bad = _check_campaign(camp, base, highpass, lowpass)
    if bad:
        return fail(bad)
    has_sheet = all({"pga_g", "pgv_over_pga_s"} <= set(t.sheet) for t in camp.tests)
    if baseline_source == "sheet" and not has_sheet:
        n = sum(not {"pga_g", "pgv_over_pga_s"} <= set(t.sheet) for t in camp.tests)
        return fail(
            f"--baseline-source sheet: {n} test(s) of {campaign} lack pga_g or pgv_over_pga_s; expected both "
            "for every test (or --baseline-source record)"
        )
    try:
        scn = load_scenario(scenario)
    except ScenarioError as exc:
        return fail(str(exc))
    try:
        settings = _parse_sets(sets)
    except Exception as exc:
        return fail(str(exc))
    ens_spec, engines = _ensemble_inputs(scn, scenario, engines, ensemble, members)
    if isinstance(ens_spec, str):
        return fail(ens_spec)
    if half_width is not None and not ensemble:
        return fail(f"--half-width {half_width}: applies to --ensemble only")
    if half_width is not None and not (0 < half_width < 0.5):
        return fail(f"--half-width {half_width}: expected a half-width of the P(topple) interval in (0, 0.5)")
    if batch < 1:
        return fail(f"--batch {batch}: expected at least 1 member per batch")
    for e in engines:
        try:
            get_engine(e)
        except Exception as exc:  # unknown engine or missing package: its install hint
            return fail(f"--engine {e}: {exc}")
    if transfer:
        bad_transfer = _check_transfer(transfer)
        if bad_transfer:
            return fail(bad_transfer)
    if calibration:
        bad_cal = _check_calibration(calibration, specimen, baseline_source, has_sheet)
        if bad_cal:
            return fail(bad_cal)
    out = out or Path("reports") / f"validate_{scn.name}"
    try:
        check_output_dir(out, "--out")
    except OutputPathError as exc:
        return fail(str(exc))
    bad = _check_scene(camp, base, scn, scenario, engines, settings, tail)
    if bad:
        return fail(bad)
    _print_inputs(console, campaign, camp, specimen, baseline_source, has_sheet)
    t0 = time.perf_counter()
    try:
        rows, motions, summary = run_campaign(
            camp, scn, engines, out, baseline=base, settings={e: settings for e in engines}, tail=tail,
            chunk_size=chunk_size, workers=workers, progress=progress, console=err,
        )  # fmt: skip
    except ScenarioError as exc:
        return fail(str(exc))
    wall = time.perf_counter() - t0
    res = evaluate(camp, rows, motions, engines, folds=folds, baseline_source=baseline_source)
    if transfer:  # issue 22: the transferred logistic baseline, fitted on another specimen
        from pbr_xval.validation.campaign_report import add_transferred

        try:
            add_transferred(res, scenario, transfer, baseline=base)
        except Exception as exc:  # the runs are done: report without it rather than lose them
            err.print(
                f"[yellow]warning:[/] --transfer {escape(transfer)}: {escape(str(exc))}", soft_wrap=True
            )
    if calibration:  # the baselines fitted on another campaign (e.g. the calibration half)
        from pbr_xval.validation.campaign_report import add_calibration_baselines

        try:
            add_calibration_baselines(res, calibration, specimen, baseline=base)
        except Exception as exc:  # the runs are done: report without them rather than lose them
            err.print(
                f"[yellow]warning:[/] --calibration {escape(calibration)}: {escape(str(exc))}", soft_wrap=True
            )
    ens_meta: dict[str, Any] = {}
    if ens_spec is not None:  # issue 22: P(topple) per test from the [uncertainty] ensemble
        from pbr_xval.validation.ensemble import run_ensemble

        ens_meta = run_ensemble(
            res, camp, motions, scn, ens_spec, out, members=members, engines=engines,
            settings={e: settings for e in engines}, tail=tail, workers=workers, progress=progress, console=err,
            half_width=half_width, batch=batch,
        )  # fmt: skip
    meta = _meta(
        campaign, camp, specimen, scenario, scn, engines, settings, base, tail, wall, summary, ens_meta
    )
    paths = write_report(res, out, meta)
    _print_scores(res, console, ens_spec is not None)
    took = f"{wall:.1f} s"  # the deterministic runs (and the baselines); an ensemble's phase is timed apart
    if "ensemble_wall_s" in ens_meta:
        took = f"deterministic runs {took}, ensemble {ens_meta['ensemble_wall_s']:.1f} s"
    console.print(
        f"wrote {escape(str(paths['html']))}, outcomes.csv, scores.csv, bands.csv ({took})", soft_wrap=True
    )
    bad = sum(res.failures.values()) + summary.failed + int(ens_meta.get("ensemble_failed_runs", 0))
    if bad:
        err.print(f"[yellow]warning:[/] {bad} run(s)/chunk(s) failed; see outcomes.csv status columns")
        return 1
    return 0


def _check_campaign(camp: Any, base: Any, highpass: float, lowpass: float) -> str | None:
    """What is wrong with the campaign's values under this baseline correction (None: nothing), before any run.

    Lab-sheet intensity measures must be ≥ 0; the filter corners must lie below the Nyquist frequency
    of every record and of the rate it is resampled to (a corner above it would be skipped or fail).
    """
    import math

    from pbr_xval.validation.campaign import SHARED_CSV

    sheet_file = camp.path / SHARED_CSV if camp.form == "shared" else camp.path
    for t in camp.tests:
        for key, unit in (("pga_g", "g"), ("pgv_over_pga_s", "s")):
            v = t.sheet.get(key)
            if v is not None and not (math.isfinite(v) and v >= 0):
                return f"{sheet_file}: test {t.test}: {key} = {v:g}; expected a value ≥ 0 {unit}"
    checked: set[float] = set()
    for t in camp.tests:
        dt = t.dt if t.dt is not None else t.raw_acceleration()[1]
        if dt in checked:
            continue
        checked.add(dt)
        fs = 1.0 / dt
        rates = [("the record", fs)]
        if base.resample_hz:
            ratio = fs / base.resample_hz
            down = round(ratio)
            if down > 1 and abs(ratio - down) <= 1e-9 * ratio:
                rates.append((f"the resampled record (--resample {base.resample_hz:g} Hz)", fs / down))
        for opt, corner in (("--highpass", base.highpass_hz), ("--lowpass", base.lowpass_hz)):
            for what, rate in rates:
                if corner and corner >= rate / 2:
                    return (
                        f"{opt} {corner:g} Hz: at or above the Nyquist frequency {rate / 2:g} Hz of {what} "
                        f"of test {t.test} ({t.source}, dt = {dt:g} s); expected a corner below it (0: none)"
                    )
    return None


def _check_scene(
    camp: Any, base: Any, scn: Any, scenario: Path, engines: list[str], settings: dict[str, Any], tail: float
) -> str | None:
    """Compile the scenario once with the first test's corrected motion and resolve every engine's
    settings (None: all good): a bad mesh or an unknown ``--set`` key is one line, not a report of
    failed runs."""
    import tempfile

    import numpy as np

    from pbr_xval.engine import get_engine
    from pbr_xval.runner import effective_settings
    from pbr_xval.scenario import scenario_from_dict
    from pbr_xval.scene import compile_scene
    from pbr_xval.validation.campaign import baseline_correct
    from pbr_xval.validation.execution import scenario_rock

    first = camp.tests[0]
    raw, dt = first.raw_acceleration()
    acc, dt = baseline_correct(raw, dt, base)
    with tempfile.TemporaryDirectory(prefix="pbr-xval-validate-") as tmp:
        motion = Path(tmp) / "motion.txt"
        np.savetxt(motion, acc)
        try:
            d = scenario_rock(scn)["scenario"]
            exc = {"type": "record", "format": "table", "units": "m/s2", "dt": dt, "path": str(motion)}
            exc["azimuth_deg"] = d.get("excitation", {}).get("azimuth_deg", 0.0)
            d.update(duration=(acc.size - 1) * dt + tail, excitation=exc)
            scene = compile_scene(scenario_from_dict(d, source=scenario))
        except Exception as exc:  # any compile failure would fail every run
            return f"{scenario}: {exc} (compiled with the motion of test {first.test})"
        for e in engines:
            try:
                effective_settings(get_engine(e), scene, settings)
            except Exception as exc:
                return f"--set for --engine {e}: {exc}"
    return None


def _ensemble_inputs(
    scn: Any, scenario: Path, engines: list[str], ensemble: bool, members: int | None
) -> tuple[Any, list[str]]:
    """(the [uncertainty] spec or None, the deterministic engines); an error message instead of the spec.

    Without ``--engine``, ``--ensemble`` runs the mixture's engines deterministically too (their
    ``F1 <engine>`` lines) and the mixture as the table gives it; with it, both are restricted.
    """
    if not ensemble:
        return None, engines
    from pbr_xval.uncertainty import ensemble_spec

    spec = ensemble_spec(scn)
    if spec is None:
        return f"--ensemble: {scenario} has no [uncertainty] table; expected one (docs/scenarios.md)", engines
    if members is not None and not 1 <= members <= 1_000_000:
        return f"--members {members}: expected 1 … 1000000 members per test", engines
    mix, _ = spec.mixture(engines)
    if not mix:
        return "--ensemble: no engine; give --engine, or engines = [...] in [uncertainty]", engines
    return spec, list(engines) or mix


def _check_calibration(spec: str, specimen: int, baseline_source: str, has_sheet: bool) -> str | None:
    """What is wrong with ``--calibration CAMPAIGN[:SPECIMEN]`` (None: nothing), before any run."""
    from pbr_xval.validation.campaign import CampaignError, load_campaign
    from pbr_xval.validation.campaign_report import calibration_source

    path, spec_n = calibration_source(spec, specimen)
    try:
        camp = load_campaign(path, spec_n)
    except (CampaignError, OSError) as exc:
        return f"--calibration {spec}: {exc}"
    if len({int(t.toppled) for t in camp.tests}) < 2:
        return f"--calibration {spec}: specimen {spec_n} has one outcome only; the rules and logistic laws need both"
    sheet = all({"pga_g", "pgv_over_pga_s"} <= set(t.sheet) for t in camp.tests)
    if (baseline_source == "sheet" or (baseline_source == "auto" and has_sheet)) and not sheet:
        return (
            f"--calibration {spec}: the baselines use the lab sheet's PGA and PGV/PGA here, but some tests of "
            f"{path} lack pga_g or pgv_over_pga_s; expected both for every test (or --baseline-source record)"
        )
    return None


def _check_transfer(spec: str) -> str | None:
    """What is wrong with ``--transfer CAMPAIGN:SPECIMEN:SCENARIO`` (None: nothing), before any run."""
    from pbr_xval.scenario import ScenarioError, load_scenario
    from pbr_xval.validation.campaign import CampaignError, load_campaign

    parts = spec.split(":")
    if len(parts) < 3 or not parts[-2].strip().isdigit():
        return f"--transfer {spec!r}: expected CAMPAIGN:SPECIMEN:SCENARIO (e.g. ../shared/data/shake_table:2:sp2.toml)"
    try:
        camp = load_campaign(":".join(parts[:-2]), int(parts[-2]))
        load_scenario(parts[-1])
    except (CampaignError, ScenarioError, OSError) as exc:
        return f"--transfer {spec}: {exc}"
    if len({int(t.toppled) for t in camp.tests}) < 2:
        return f"--transfer {spec}: the source specimen has one outcome only; a logistic law needs both"
    return None
