"""Regenerate the sample inputs of the examples (deterministic; run from the repository root).

* ``examples/rocks/synthetic_pbr.obj`` — a PBR-like rock from
  ``pbr_xval.geometry.synthetic.synthetic_rock(seed=11, subdivisions=3, unevenness=0.0,
  base_fraction=0.06)``: 642 vertices, about 0.7 × 0.5 × 1.0 m, resting on a flat base; it
  stands in for a scan (``pbr-xval rock`` reads it like any mesh scan).
* ``examples/records/synthetic_accelerogram.AT2`` (PEER format, g) and
  ``examples/records/synthetic_accelerogram.txt`` (a text table with a header: ``time_s``,
  ``acc_cm_s2``) — the same 10 s record at dt = 0.01 s from
  ``pbr_xval.motion.processing.synthetic_accelerogram(seed=2026)``: band-passed (0.3–8 Hz)
  white noise under a Saragoni–Hart envelope, baseline-corrected to zero final velocity and
  displacement, PGA 0.3 g (2.942 m/s²).
* ``examples/rocks/scanned_rock.toml`` — written by ``pbr-xval rock examples/rocks/synthetic_pbr.obj
  --scenario examples/rocks/scanned_rock.toml``.

``tests/geometry/test_geometry_pipeline.py`` and ``tests/motion/test_records.py`` check that the committed files are what this script makes.

Usage: ``python examples/make_sample_inputs.py``
"""

from __future__ import annotations

from pathlib import Path

HERE = Path(__file__).resolve().parent
ROCK = dict(seed=11, subdivisions=3, unevenness=0.0, base_fraction=0.06)
RECORD = dict(seed=2026)


def make_rock(path: Path = HERE / "rocks" / "synthetic_pbr.obj") -> Path:
    from pbr_xval.atomic import write_text_atomic
    from pbr_xval.geometry.synthetic import synthetic_rock

    mesh, _ = synthetic_rock(**ROCK)
    write_text_atomic(path, mesh.export(file_type="obj"))
    return path


def make_records(folder: Path = HERE / "records") -> tuple[Path, Path]:
    from pbr_xval.motion.processing import synthetic_accelerogram
    from pbr_xval.motion.records import write_at2, write_table

    rec = synthetic_accelerogram(**RECORD)
    folder.mkdir(parents=True, exist_ok=True)
    at2 = write_at2(
        rec, folder / "synthetic_accelerogram.AT2", header="pbr-xval synthetic accelerogram, seed 2026"
    )
    txt = write_table(
        rec,
        folder / "synthetic_accelerogram.txt",
        units="cm/s2",
        comment=(
            "pbr-xval synthetic accelerogram, seed 2026 (examples/make_sample_inputs.py)\n"
            "time in s, acceleration in cm/s2; baseline-corrected, PGA 0.3 g"
        ),
    )
    return at2, txt


def make_scenario(path: Path = HERE / "rocks" / "scanned_rock.toml") -> Path:
    from pbr_xval.cli.rock_impl import write_rock_scenario
    from pbr_xval.geometry.rockmodel import build_rock_model

    scan = HERE / "rocks" / "synthetic_pbr.obj"
    model = build_rock_model(scan, density=2600.0, pose="settle", n_directions=72)
    write_rock_scenario(model, scan, path, pose="settle", density=2600.0)
    return path


if __name__ == "__main__":
    print(make_rock(), *make_records(), make_scenario(), sep="\n")
