"""Rock catalogs: a list of rocks × a motion set, validated up front.

A catalog is a TOML file (the rock list may instead be a CSV file referenced from it)::

    name = "demo"
    seed = 20240601            # catalog seed: every chunk's random stream derives from it
    duration = 4.0             # s after the start of the excitation, or "auto" (motion + tail)
    engines = ["housner", "mujoco"]
    chunk_size = 8             # motions per chunk

    [settings.mujoco]          # per-engine settings overrides
    timestep = 2e-3

    [[rock]]
    id = "box_a"
    shape = "box"              # box | notched_block | curved_base | mesh | synthetic
    half_extents = [0.2, 0.2, 0.6]
    density = 2400.0           # or mass (kg)
    friction = 0.8             # or friction_min / friction_max (sampled per run)
    [rock.site]
    name = "Echo Cliffs"; lat = 34.1; lon = -118.9

    [motions]
    [[motions.pulse]]          # one grid: the cartesian product of every list
    type = "half_sine"
    amplitude = [2.0, 4.0, 6.0]
    frequency = [1.0, 2.0]

    [motions.records]          # or: a folder of records scaled to a PGA (or PGV) list
    folder = "records"
    pattern = "*.AT2"
    pga = [1.0, 2.0, 4.0]

Everything is validated before anything runs; every bad entry gives one line naming the file,
the ``[[rock]]`` index (TOML) or the row (CSV), the key, what was found and what was expected,
and :class:`CatalogError` carries all of them.
"""

from __future__ import annotations

import csv
import itertools
import math
import re
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, TypeAdapter, ValidationError

from pbr_xval.hashing import file_sha256
from pbr_xval.tomlio import error_parts, key_line, read_toml, resolve_path, validation_lines
from pbr_xval.units import UNIT_SCALE

__all__ = ["Catalog", "CatalogError", "catalog_from_dict", "load_catalog"]

SHAPES = ("box", "notched_block", "curved_base", "mesh", "synthetic")
#: keys each rock shape takes (besides the common keys)
SHAPE_KEYS: dict[str, dict[str, bool]] = {  # key -> required
    "box": {"half_extents": True},
    "notched_block": {"half_extents": True, "notch_width": True, "notch_height": True},
    "curved_base": {"H": True, "r": True, "h": True, "depth": False, "arc_segments": False},
    "mesh": {"path": True, "units": False, "pose": False, "orientation": False},
    "synthetic": {
        "seed": True,
        "radii": False,
        "roughness": False,
        "base_fraction": False,
        "unevenness": False,
        "subdivisions": False,
        "target_alpha_deg": False,
    },
}
COMMON_KEYS = {
    "id", "shape", "density", "mass", "friction", "friction_min", "friction_max", "restitution",
    "pedestal", "azimuth_deg", "site", "site_name", "lat", "lon", "notes", "yaw_deg",
}  # fmt: skip
ALL_ROCK_KEYS = COMMON_KEYS | {k for d in SHAPE_KEYS.values() for k in d}
PULSE_TYPES = ("half_sine", "sawtooth", "one_sine", "one_cosine", "rectangular", "ricker")
_ID = re.compile(r"^[A-Za-z0-9_.\-]+$")


class CatalogError(ValueError):
    """A catalog is invalid; one line per bad entry (file, row / index, key, found, expected)."""

    def __init__(self, lines: list[str]):
        self.lines = list(lines)
        super().__init__("\n".join(self.lines))


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


class Site(_Strict):
    name: str = ""
    lat: float | None = Field(None, ge=-90, le=90)
    lon: float | None = Field(None, ge=-180, le=180)
    notes: str = ""


class ChooseSpec(_Strict):
    """The ``[choose]`` table: calibration subset and candidate settings."""

    rocks: int | list[str] = Field(2, description="first n rocks, or a list of rock ids")
    motions: int = Field(8, ge=1, description="motions per rock, evenly spaced over the motion list")
    engines: list[str] | None = Field(None, description="candidate engines (default: the catalog's engines)")
    timesteps: list[float] = Field(default_factory=lambda: [1e-2, 5e-3, 2e-3, 1e-3, 5e-4])
    profiles: list[str] = Field(default_factory=lambda: ["faithful", "engine-default"])
    reference_engine: str = "reference"
    fallback_engine: str = "housner"
    reference_max_seconds: float = Field(60.0, gt=0, description="per simulation; slower → fallback")
    min_runs_for_fit: int = Field(
        6, ge=2, description="runs per rock below which the agreement metric is used"
    )
    cores: int = Field(100, ge=1, description="cores for the projected wall time")


class Catalog(BaseModel):
    """A validated catalog (rocks and motions fully expanded)."""

    name: str
    source: str | None = None
    seed: int = 0
    duration: float | Literal["auto"] = 5.0
    tail: float = 3.0
    settle_time: float = 0.5
    output_dt: float = 1e-2
    engines: list[str]
    profile: str | None = None
    settings: dict[str, dict[str, Any]] = Field(default_factory=dict)
    chunk_size: int = 8
    rocks: list[dict[str, Any]]
    motions: list[dict[str, Any]]
    choose: ChooseSpec = Field(default_factory=ChooseSpec)

    def rock(self, rock_id: str) -> dict[str, Any]:
        for r in self.rocks:
            if r["id"] == rock_id:
                return r
        raise KeyError(rock_id)

    def motion_duration(self, motion: dict[str, Any]) -> float:
        if self.duration == "auto":
            return float(motion.get("duration", 0.0)) + self.tail
        return float(self.duration)


_TOP_KEYS = {
    "name", "seed", "duration", "tail", "settle_time", "output_dt", "engines", "profile", "settings",
    "chunk_size", "rock", "rocks_csv", "motions", "choose", "description",
}  # fmt: skip


# ---------------------------------------------------------------- helpers
_fmt = key_line


def _untagged(loc: tuple[Any, ...]) -> list[str]:
    """Key components of a pydantic location without union tags (e.g. "box", "function-after[...]")."""
    parts = [str(p) for p in loc]
    return [p for p in parts if not p.startswith("function-") and p not in SHAPES and p not in PULSE_TYPES]


def _first_error(exc: ValidationError, prefix: str = "") -> tuple[str, str, Any]:
    return error_parts(exc.errors()[0], prefix=prefix, loc=_untagged)


def _num(v: Any, key: str) -> float:
    if isinstance(v, bool) or not isinstance(v, int | float):
        raise _KeyError(key, "not a number", v, "a number")
    x = float(v)
    if not math.isfinite(x):
        raise _KeyError(key, "not finite", v, "a finite number")
    return x


class _KeyError(Exception):
    def __init__(self, key: str, msg: str, found: Any = None, expected: str | None = None):
        super().__init__(key)
        self.key, self.msg, self.found, self.expected = key, msg, found, expected


# ---------------------------------------------------------------- rocks
def _validate_rock(raw: dict[str, Any], base: Path, seen: set[str]) -> dict[str, Any]:
    """A normalised rock dict, or :class:`_KeyError`."""
    from pbr_xval import scenario as sc

    for k in raw:
        if k not in ALL_ROCK_KEYS:
            raise _KeyError(k, "unknown key", None, "one of " + ", ".join(sorted(ALL_ROCK_KEYS)))
    rid = raw.get("id")
    if rid is None:
        raise _KeyError("id", "missing required key", None, "a rock id (letters, digits, _ . -)")
    if not isinstance(rid, str) or not _ID.match(rid):
        raise _KeyError("id", "invalid rock id", rid, "letters, digits, '_', '.', '-'")
    if rid in seen:
        raise _KeyError("id", "duplicate rock id", rid, "ids unique within the catalog")
    shape = raw.get("shape")
    if shape not in SHAPES:
        raise _KeyError(
            "shape",
            "unknown shape" if shape is not None else "missing required key",
            shape,
            "one of " + ", ".join(SHAPES),
        )
    keys = SHAPE_KEYS[shape]
    for k in raw:
        if k not in COMMON_KEYS and k not in keys:
            raise _KeyError(k, f"not a key of shape {shape!r}", raw[k], "one of " + ", ".join(sorted(keys)))
    for k, req in keys.items():
        if req and raw.get(k) is None:
            raise _KeyError(k, f"missing required key for shape {shape!r}")
    out: dict[str, Any] = {"id": rid, "shape": shape}
    # mass
    if raw.get("density") is not None and raw.get("mass") is not None:
        raise _KeyError("mass", "give either 'density' or 'mass', not both", raw["mass"], "one of them")
    if raw.get("density") is None and raw.get("mass") is None:
        raise _KeyError("density", "missing required key", None, "'density' (kg/m³) or 'mass' (kg)")
    for k in ("density", "mass"):
        if raw.get(k) is not None:
            x = _num(raw[k], k)
            if x <= 0:
                raise _KeyError(k, "must be > 0", raw[k], "a positive number")
            out[k] = x
    # friction
    f, fmin, fmax = raw.get("friction"), raw.get("friction_min"), raw.get("friction_max")
    if f is not None and (fmin is not None or fmax is not None):
        raise _KeyError("friction", "give 'friction' or 'friction_min'/'friction_max', not both", f)
    if f is None and fmin is None and fmax is None:
        f = 1.0
    if f is not None:
        x = _num(f, "friction")
        if x < 0:
            raise _KeyError("friction", "must be >= 0", f, "a friction coefficient >= 0")
        out["friction_min"] = out["friction_max"] = x
    else:
        if fmin is None or fmax is None:
            missing = "friction_min" if fmin is None else "friction_max"
            raise _KeyError(missing, "missing required key (a friction range needs both ends)")
        a, b = _num(fmin, "friction_min"), _num(fmax, "friction_max")
        if a < 0:
            raise _KeyError("friction_min", "must be >= 0", fmin, "a friction coefficient >= 0")
        if b < a:
            raise _KeyError("friction_max", f"must be >= friction_min = {a}", fmax, "μ_max >= μ_min")
        out["friction_min"], out["friction_max"] = a, b
    rest = raw.get("restitution", 0.0)
    x = _num(rest, "restitution")
    if not 0 <= x <= 1:
        raise _KeyError("restitution", "out of range", rest, "a number in [0, 1]")
    out["restitution"] = x
    out["azimuth_deg"] = _num(raw.get("azimuth_deg", 0.0), "azimuth_deg")
    out["yaw_deg"] = _num(raw.get("yaw_deg", 0.0), "yaw_deg")
    # pedestal
    ped = raw.get("pedestal", {"kind": "plane"})
    if isinstance(ped, str):
        ped = {"kind": ped}
    try:
        ped_m = TypeAdapter(sc.Pedestal).validate_python(ped)
    except ValidationError as exc:
        key, msg, found = _first_error(exc, "pedestal")
        raise _KeyError(
            key, msg, found, "a pedestal table: kind = plane | box (half_extents) | mesh (path)"
        ) from None
    ped_d = ped_m.model_dump(mode="json")
    if ped_d["kind"] == "mesh":
        p = _resolve(ped_d["path"], base)
        if not p.is_file():
            raise _KeyError("pedestal.path", "file not found", str(p), "an existing mesh file")
        ped_d["path"] = str(p)
        ped_d["sha256"] = file_sha256(p)
    out["pedestal"] = ped_d
    # site
    site = dict(raw.get("site") or {})
    for k_flat, k in (("site_name", "name"), ("lat", "lat"), ("lon", "lon"), ("notes", "notes")):
        if raw.get(k_flat) is not None:
            site[k] = raw[k_flat]
    try:
        out["site"] = Site.model_validate(site).model_dump(mode="json")
    except ValidationError as exc:
        key, msg, found = _first_error(exc, "site")
        raise _KeyError(key, msg, found) from None
    # shape parameters
    params = {k: raw[k] for k in keys if raw.get(k) is not None}
    if shape == "synthetic":
        try:
            syn = _Synthetic.model_validate(params)
        except ValidationError as exc:
            key, msg, found = _first_error(exc)
            raise _KeyError(key, msg, found) from None
        out.update(syn.model_dump(mode="json"))
    else:
        rock_d = {"shape": shape, **params, "density": 1.0}
        if shape == "mesh":
            p = _resolve(str(params["path"]), base)
            if not p.is_file():
                raise _KeyError(
                    "path", "file not found", str(p), "an existing mesh file (OBJ, PLY, STL, OFF)"
                )
            rock_d["path"] = str(p)
        try:
            model = TypeAdapter(sc.Rock).validate_python(rock_d)
        except ValidationError as exc:
            key, msg, found = _first_error(exc)
            raise _KeyError(key, msg, found) from None
        if isinstance(model, sc.MeshRock):  # read now: a garbage or NaN mesh is one line, not failed rows
            from pbr_xval.geometry.interface import load_rock_mesh

            try:
                load_rock_mesh(rock_d["path"], units=model.units, pose=model.pose, hint='use pose = "settle"')
            except (ValueError, OSError) as exc:
                raise _KeyError("path", f"unusable mesh ({exc})", None, "a closed rock mesh") from None
        out.update({k: v for k, v in rock_d.items() if k not in ("shape", "density")})
        if shape == "mesh":
            out["sha256"] = file_sha256(Path(out["path"]))
    return out


class _Synthetic(_Strict):
    seed: int = Field(ge=0)
    radii: list[float] = Field(default_factory=lambda: [0.35, 0.25, 0.55], min_length=3, max_length=3)
    roughness: float = Field(0.12, ge=0, lt=1)
    base_fraction: float = Field(0.04, gt=0, lt=0.5)
    unevenness: float = Field(0.004, ge=0)
    subdivisions: int = Field(3, ge=1, le=6)
    target_alpha_deg: float | None = Field(None, gt=0, lt=60)


_resolve = resolve_path


def _csv_value(key: str, text: str) -> Any:
    text = text.strip()
    if text == "":
        return None
    if key in ("id", "shape", "path", "units", "pose", "orientation", "site_name", "notes", "pedestal"):
        return text
    if key in ("half_extents", "radii"):
        parts = [p for p in re.split(r"[\s;|]+", text.strip("[]")) if p]
        try:
            return [float(p) for p in parts]
        except ValueError:
            raise _KeyError(
                key, "not a list of numbers", text, "numbers separated by spaces or ';'"
            ) from None
    if key in ("seed", "subdivisions", "arc_segments"):
        try:
            return int(text)
        except ValueError:
            raise _KeyError(key, "not an integer", text, "an integer") from None
    try:
        return float(text)
    except ValueError:
        raise _KeyError(key, "not a number", text, "a number") from None


def _rocks_from_csv(path: Path, errors: list[str]) -> list[tuple[str, dict[str, Any]]]:
    """(where, raw rock dict) per data row of a CSV rock list."""
    out: list[tuple[str, dict[str, Any]]] = []
    try:
        text = path.read_text()
    except OSError as exc:
        errors.append(f"{path}: cannot read rock list ({exc.strerror})")
        return out
    lines = [ln for ln in text.splitlines()]
    reader = csv.reader(lines)
    try:
        header = [h.strip() for h in next(reader)]
    except StopIteration:
        errors.append(f"{path}: empty rock list; expected a header row (id,shape,...)")
        return out
    for h in header:
        if h not in ALL_ROCK_KEYS and not h.startswith("#"):
            errors.append(
                _fmt(
                    f"{path}: header", h, "unknown column", None, "one of " + ", ".join(sorted(ALL_ROCK_KEYS))
                )
            )
            return out
    for n, row in enumerate(reader, start=1):
        line = n + 1
        if not row or all(not c.strip() for c in row) or row[0].lstrip().startswith("#"):
            continue
        where = f"{path}: row {n} (line {line})"
        if len(row) > len(header):
            errors.append(f"{where}: {len(row)} fields but the header has {len(header)}")
            continue
        raw: dict[str, Any] = {}
        try:
            for h, cell in zip(header, row, strict=False):
                v = _csv_value(h, cell)
                if v is not None:
                    raw[h] = v
        except _KeyError as e:
            errors.append(_fmt(where, e.key, e.msg, e.found, e.expected))
            continue
        out.append((where, raw))
    return out


# ---------------------------------------------------------------- motions
def _grid_points(raw: dict[str, Any], where: str) -> list[dict[str, Any]]:
    from pbr_xval import scenario as sc

    raw = dict(raw)
    ptype = raw.get("type")
    if ptype not in PULSE_TYPES:
        raise _KeyError(
            "type",
            "unknown pulse type" if ptype else "missing required key",
            ptype,
            "one of " + ", ".join(PULSE_TYPES),
        )
    keys = sorted(k for k in raw if k != "type")
    grids = []
    for k in keys:
        v = raw[k]
        vals = v if isinstance(v, list) else [v]
        if not vals:
            raise _KeyError(k, "empty list", v, "at least one value")
        grids.append(vals)
    adapter = TypeAdapter(sc.Excitation)
    pts = []
    for combo in itertools.product(*grids):
        exc = {"type": ptype, **dict(zip(keys, combo, strict=True))}
        try:
            adapter.validate_python(exc)
        except ValidationError as e:
            key, msg, found = _first_error(e)
            raise _KeyError(key, msg, found, f"a valid {ptype} pulse parameter") from None
        params = {k: exc[k] for k in keys}
        mid = ptype + "_" + "_".join(f"{_short(k)}{_g(v)}" for k, v in params.items())
        pts.append({"id": mid, "kind": "pulse", "excitation": exc, "params": params})
    return pts


def _short(k: str) -> str:
    return {"amplitude": "a", "frequency": "f", "period": "T", "pgv": "v", "phase": "ph", "skew": "s",
            "pulse_duration": "td", "start_time": "t0", "t0": "tc"}.get(k, k)  # fmt: skip


def _g(v: Any) -> str:
    return f"{v:g}" if isinstance(v, float | int) and not isinstance(v, bool) else str(v)


class _Records(_Strict):
    folder: str
    pattern: str = "*"
    format: Literal["auto", "at2", "table"] = "auto"
    units: Literal["m/s2", "g", "cm/s2"] = "m/s2"
    dt: float | None = Field(None, gt=0)
    pga: list[float] | None = Field(None, min_length=1, description="target PGAs, m/s²")
    pgv: list[float] | None = Field(None, min_length=1, description="target PGVs, m/s")
    scale: list[float] | None = Field(None, min_length=1, description="plain scale factors")


def _record_motions(raw: dict[str, Any], base: Path) -> list[dict[str, Any]]:
    from pbr_xval.motion import read_record

    try:
        spec = _Records.model_validate(raw)
    except ValidationError as exc:
        key, msg, found = _first_error(exc)
        raise _KeyError(key, msg, found) from None
    n_given = sum(x is not None for x in (spec.pga, spec.pgv, spec.scale))
    if n_given > 1:
        raise _KeyError("pga", "give one of 'pga', 'pgv', 'scale'", None, "a single scaling list")
    for k in ("pga", "pgv", "scale"):
        for v in getattr(spec, k) or []:
            if not (v > 0 and math.isfinite(v)):
                raise _KeyError(k, "must be > 0", v, "positive numbers")
    folder = _resolve(spec.folder, base)
    if not folder.is_dir():
        raise _KeyError("folder", "folder not found", str(folder), "an existing folder of records")
    files = sorted(p for p in folder.glob(spec.pattern) if p.is_file())
    if not files:
        raise _KeyError(
            "pattern", f"no files match in {folder}", spec.pattern, "a glob matching record files"
        )
    out = []
    for f in files:
        kw: dict[str, Any] = {}
        is_at2 = spec.format == "at2" or (spec.format == "auto" and f.suffix.lower() == ".at2")
        if not is_at2:
            kw = {"dt": spec.dt, "units": spec.units}
        try:
            rec = read_record(f, format=spec.format, **kw)
        except Exception as exc:  # MotionFileError and friends: name the file
            raise _KeyError("folder", f"cannot read record {f.name}: {exc}", None) from None
        sha = file_sha256(f)
        levels: list[tuple[str, float | None]]
        if spec.pga:
            levels = [("target_pga", v) for v in spec.pga]
        elif spec.pgv:
            levels = [("target_pgv", v) for v in spec.pgv]
        else:
            levels = [("scale", v) for v in (spec.scale or [1.0])]
        for key, v in levels:
            exc_d: dict[str, Any] = {"type": "record", "format": spec.format, key: v}
            if not is_at2:
                exc_d["units"] = spec.units
                if spec.dt is not None:
                    exc_d["dt"] = spec.dt
            tag = {"target_pga": "pga", "target_pgv": "pgv", "scale": "x"}[key]
            out.append(
                {
                    "id": f"{_safe(f.stem)}@{tag}{_g(v)}",
                    "kind": "record",
                    "excitation": exc_d,
                    "params": {"record": f.name, key: v},
                    "path": str(f),
                    "sha256": sha,
                    "duration": float(rec.duration),
                }
            )
    return out


def _safe(s: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.\-]", "_", s)


# ---------------------------------------------------------------- loading
def load_catalog(path: str | Path) -> Catalog:
    """Read and validate a catalog TOML file (and the CSV rock list it names).

    Raises
    ------
    CatalogError
        one line per bad entry; nothing is run until the whole catalog is valid.
    """
    path = Path(path)
    if path.suffix.lower() == ".csv" and path.is_file():  # a bare rock list: no motions
        raise CatalogError(
            [
                f"{path}: a CSV file is a rock list; reference it from a catalog TOML as rocks_csv = '{path.name}'"
            ]
        )
    data = read_toml(
        path, what="catalog", expected="[[rock]] tables and [motions]", error=lambda m: CatalogError([m])
    )
    return catalog_from_dict(data, source=path)


def catalog_from_dict(data: dict[str, Any], *, source: Path | None = None) -> Catalog:
    where = str(source) if source else "<catalog>"
    base = Path(source).resolve().parent if source else Path.cwd()
    errors: list[str] = []
    for k in data:
        if k not in _TOP_KEYS:
            errors.append(_fmt(where, k, "unknown key", None, "one of " + ", ".join(sorted(_TOP_KEYS))))
    # rocks
    entries: list[tuple[str, dict[str, Any]]] = []
    rock_tables = data.get("rock", [])
    if not isinstance(rock_tables, list):
        errors.append(_fmt(where, "rock", "not an array of tables", None, "[[rock]] entries"))
        rock_tables = []
    for i, r in enumerate(rock_tables, start=1):
        rid = r.get("id") if isinstance(r, dict) else None
        entries.append((f"{where}: [[rock]] {i}" + (f" (id {rid!r})" if rid else ""), r))
    if data.get("rocks_csv") is not None:
        csv_path = _resolve(str(data["rocks_csv"]), base)
        if not csv_path.is_file():
            errors.append(
                _fmt(where, "rocks_csv", "file not found", str(csv_path), "an existing CSV rock list")
            )
        else:
            entries += _rocks_from_csv(csv_path, errors)
    if not entries and not errors:
        errors.append(_fmt(where, "rock", "no rocks", None, "[[rock]] tables or rocks_csv = 'rocks.csv'"))
    rocks: list[dict[str, Any]] = []
    seen: set[str] = set()
    for w, raw in entries:
        if not isinstance(raw, dict):
            errors.append(f"{w}: not a table")
            continue
        try:
            rock = _validate_rock(raw, base, seen)
        except _KeyError as e:
            errors.append(_fmt(w, e.key, e.msg, e.found, e.expected))
            continue
        seen.add(rock["id"])
        rocks.append(rock)
    # motions
    motions: list[dict[str, Any]] = []
    mt = data.get("motions")
    if not isinstance(mt, dict):
        errors.append(
            _fmt(
                where,
                "motions",
                "missing required table",
                None,
                "[[motions.pulse]] grids or [motions.records]",
            )
        )
    else:
        for k in mt:
            if k not in ("pulse", "records"):
                errors.append(_fmt(f"{where}: [motions]", k, "unknown key", None, "'pulse' or 'records'"))
        pulses = mt.get("pulse", [])
        if isinstance(pulses, dict):
            pulses = [pulses]
        for i, g in enumerate(pulses, start=1):
            w = f"{where}: [[motions.pulse]] {i}"
            try:
                motions += _grid_points(g, w)
            except _KeyError as e:
                errors.append(_fmt(w, e.key, e.msg, e.found, e.expected))
        recs = mt.get("records", [])
        if isinstance(recs, dict):
            recs = [recs]
        for i, r in enumerate(recs, start=1):
            w = f"{where}: [motions.records]" + (f" {i}" if len(recs) > 1 else "")
            try:
                motions += _record_motions(r, base)
            except _KeyError as e:
                errors.append(_fmt(w, e.key, e.msg, e.found, e.expected))
        if not motions and not errors:
            errors.append(
                _fmt(f"{where}: [motions]", "pulse", "no motions", None, "at least one pulse grid or record")
            )
        ids = [m["id"] for m in motions]
        dups = sorted({x for x in ids if ids.count(x) > 1})
        if dups:
            errors.append(
                _fmt(
                    f"{where}: [motions]",
                    "id",
                    "duplicate motion ids",
                    dups[:5],
                    "distinct grid points / records",
                )
            )
    # top level
    top: dict[str, Any] = {
        k: data[k]
        for k in (
            "name",
            "seed",
            "duration",
            "tail",
            "settle_time",
            "output_dt",
            "engines",
            "profile",
            "settings",
            "chunk_size",
        )
        if k in data
    }
    top.setdefault("name", Path(where).stem if source else "catalog")
    top.setdefault("engines", ["housner"])
    if "choose" in data:
        try:
            top["choose"] = ChooseSpec.model_validate(data["choose"])
        except ValidationError as exc:
            key, msg, found = _first_error(exc, "choose")
            errors.append(_fmt(where, key, msg, found))
    try:
        _Top.model_validate(top)
    except ValidationError as exc:
        errors += validation_lines(exc, where)
    else:
        errors += _engine_errors(top, motions, where)
    if errors:
        raise CatalogError(errors)
    return Catalog(**top, source=str(source) if source else None, rocks=rocks, motions=motions)


def _engine_errors(top: dict[str, Any], motions: list[dict[str, Any]], where: str) -> list[str]:
    """Engines registered, settings in range (:mod:`pbr_xval.settings_spec`), run sizes bounded."""
    from pbr_xval.engine import registered_names
    from pbr_xval.settings_spec import check_sample_count, check_settings, check_step_count

    known = registered_names()
    expected = "one of " + ", ".join(known)
    out: list[str] = []
    for i, name in enumerate(top["engines"]):
        if name not in known:
            out.append(_fmt(where, f"engines[{i}]", "unknown engine", name, expected))
    settings = top.get("settings") or {}
    for name, table in settings.items():
        if name not in known:
            out.append(_fmt(where, f"settings.{name}", "unknown engine", name, expected))
            continue
        out += check_settings(name, table, complete=False, where=f"{where}: key 'settings.{name}'")
    choose = top.get("choose")
    if choose is not None:
        for key in ("reference_engine", "fallback_engine"):
            if getattr(choose, key) not in known:
                out.append(_fmt(where, f"choose.{key}", "unknown engine", getattr(choose, key), expected))
        for i, name in enumerate(choose.engines or []):
            if name not in known:
                out.append(_fmt(where, f"choose.engines[{i}]", "unknown engine", name, expected))
        for i, dt in enumerate(choose.timesteps):
            if not check_settings("", {"timestep": dt}) == []:
                out.append(
                    _fmt(where, f"choose.timesteps[{i}]", "not a time step", dt, "a number > 0 and ≤ 1 s")
                )
    if out:
        return out
    # run sizes: the longest run of the catalog
    duration = top.get("duration", 5.0)
    if duration == "auto":
        duration = max((float(m.get("duration", 0.0)) for m in motions), default=0.0) + float(
            top.get("tail", 3.0)
        )
    problem = check_sample_count(
        float(duration), float(top.get("output_dt", 1e-2)), where=f"{where}: key 'output_dt'"
    )
    if problem:
        out.append(problem)
    for name in top["engines"]:
        problem = check_step_count(
            name, settings.get(name, {}), float(duration), float(top.get("settle_time", 0.5)),
            where=f"{where}: key 'settings.{name}.timestep'",
        )  # fmt: skip
        if problem:
            out.append(problem)
    return out


class _Top(_Strict):
    name: str = Field(pattern=r"^[A-Za-z0-9_.\-]+$")
    seed: int = Field(0, ge=0)
    duration: Annotated[float, Field(gt=0, allow_inf_nan=False)] | Literal["auto"] = 5.0
    tail: float = Field(3.0, ge=0)
    settle_time: float = Field(0.5, ge=0)
    output_dt: float = Field(1e-2, gt=0)
    engines: list[str] = Field(min_length=1)
    profile: str | None = None
    settings: dict[str, dict[str, Any]] = Field(default_factory=dict)
    chunk_size: int = Field(8, ge=1)
    choose: ChooseSpec | None = None


def units_scale(units: str) -> float:
    return UNIT_SCALE[units]
