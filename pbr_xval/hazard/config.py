"""The ``pbr-xval constrain`` input file (TOML): hazard branches or fractiles, rocks, ages.

::

    name = "my-site"
    joint = "independent"          # or "shared-events"
    rate_of_interest = 1e-4        # 1/yr, where the report compares IMs before and after
    quantiles = [0.05, 0.5, 0.95]

    [hazard]
    tail = "powerlaw"              # or "cut"
    site = [-118.92, 34.08]        # lon, lat — when a file holds several sites
    [[hazard.branch]]              # logic-tree branches (plain CSV, OpenQuake CSV or NRML XML) …
    file = "hazard/hazard_curve-rlz-000-PGA_0.csv"
    weight = 0.09
    # … or fractile curves instead of branches:
    # [[hazard.quantile]]
    # file = "hazard/quantile_curve-0.05-PGA_0.csv"
    # q = 0.05
    # mean = "hazard/hazard_curve-mean-PGA_0.csv"   # optional with fractiles: drawn for reference

    [[rock]]
    id = "rock_A"
    fragility = "fragility/rocks.xml"   # NRML fragilityModel or fragility CSV
    function = "rock_A"                 # function id in that file (default: the rock id)
    age = 12000.0                       # exposure age, yr
    age_sd = 1200.0                     # yr
    age_dist = "normal"                 # normal | lognormal | fixed

Paths are relative to the TOML file. Each error is one line naming the file, the table and key.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pbr_xval.hazard.curves import HazardCurve, read_hazard_curves
from pbr_xval.hazard.ims import HazardInputError
from pbr_xval.hazard.survival import Age, RockInput, branches_from_quantiles

__all__ = ["ConstrainConfig", "load_config"]

_TOP = {"name", "joint", "rate_of_interest", "quantiles", "hazard", "rock", "description"}


@dataclass
class ConstrainConfig:
    name: str
    branches: list[HazardCurve]
    rocks: list[RockInput]
    joint: str = "independent"
    rate_of_interest: float = 1e-4
    quantiles: tuple[float, ...] = (0.05, 0.5, 0.95)
    hazard_mode: str = "branches"
    path: Path = field(default_factory=Path)
    notes: list[str] = field(default_factory=list)
    given_mean: HazardCurve | None = None


def _req(d: dict[str, Any], key: str, where: str, expected: str) -> Any:
    if key not in d:
        raise HazardInputError(f"{where}: key '{key}' missing; expected {expected}")
    return d[key]


def _pos(v: Any, where: str, key: str, allow_zero: bool = False) -> float:
    try:
        x = float(v)
    except (TypeError, ValueError):
        raise HazardInputError(f"{where}: key '{key}': {v!r}; expected a number") from None
    if not math.isfinite(x) or x < 0 or (x == 0 and not allow_zero):
        raise HazardInputError(
            f"{where}: key '{key}': {v!r}; expected a {'non-negative' if allow_zero else 'positive'} number"
        )
    return x


def load_config(path: str | Path) -> ConstrainConfig:
    """Read and validate a constrain TOML; reads every hazard and fragility file it names."""
    from pbr_xval.hazard.nrml import read_fragility_csv, read_fragility_model

    p = Path(path)
    if not p.is_file():
        raise HazardInputError(f"{p}: file not found; expected a constrain TOML file")
    try:
        raw = tomllib.loads(p.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as exc:
        raise HazardInputError(f"{p}: invalid TOML ({exc})") from None
    if not raw:
        raise HazardInputError(f"{p}: empty file; expected [hazard] and [[rock]] tables")
    unknown = sorted(set(raw) - _TOP)
    if unknown:
        raise HazardInputError(f"{p}: unknown key(s) {unknown}; expected some of {sorted(_TOP)}")
    base = p.parent
    joint = raw.get("joint", "independent")
    if joint not in ("independent", "shared-events"):
        raise HazardInputError(f"{p}: key 'joint': {joint!r}; expected 'independent' or 'shared-events'")
    rate = _pos(raw.get("rate_of_interest", 1e-4), str(p), "rate_of_interest")
    qs = tuple(float(q) for q in raw.get("quantiles", (0.05, 0.5, 0.95)))
    if not all(0 < q < 1 for q in qs):
        raise HazardInputError(f"{p}: key 'quantiles': {list(qs)}; expected values in (0, 1)")
    hz = _req(raw, "hazard", str(p), "a [hazard] table")
    where = f"{p} [hazard]"
    tail = hz.get("tail", "powerlaw")
    if tail not in ("powerlaw", "cut"):
        raise HazardInputError(f"{where}: key 'tail': {tail!r}; expected 'powerlaw' or 'cut'")
    site = hz.get("site")
    site_t = (float(site[0]), float(site[1])) if site else None
    branches: list[HazardCurve] = []
    notes: list[str] = []
    mode = "branches"
    if "branch" in hz and "quantile" in hz:
        raise HazardInputError(f"{where}: both 'branch' and 'quantile' given; expected one of them")
    if "branch" in hz:
        for i, b in enumerate(hz["branch"]):
            w = f"{p} [[hazard.branch]] #{i + 1}"
            f = base / str(_req(b, "file", w, "a hazard-curve file"))
            cs = read_hazard_curves(f, site_t, tail)
            for c in cs:
                c.weight = _pos(b.get("weight", 1.0), w, "weight", allow_zero=True)
                c.name = str(b.get("name", c.name if len(cs) > 1 else f.stem))
            branches.extend(cs)
    elif "quantile" in hz:
        mode = "quantiles"
        curves, qv = [], []
        for i, b in enumerate(hz["quantile"]):
            w = f"{p} [[hazard.quantile]] #{i + 1}"
            f = base / str(_req(b, "file", w, "a hazard-curve file"))
            q = _pos(_req(b, "q", w, "the fractile, e.g. 0.05"), w, "q")
            curves.append(read_hazard_curves(f, site_t, tail)[0])
            qv.append(q)
        order = sorted(range(len(qv)), key=lambda i: qv[i])
        branches = branches_from_quantiles([curves[i] for i in order], [qv[i] for i in order])
        notes.append("hazard given as fractile curves: each is a branch weighted by the interval between midpoints "
                     "to its neighbouring fractiles (an approximation of the distribution)")  # fmt: skip
    else:
        raise HazardInputError(f"{where}: no [[hazard.branch]] or [[hazard.quantile]]; expected one of them")
    given_mean = None
    if "mean" in hz:
        if mode != "quantiles":
            raise HazardInputError(
                f"{where}: key 'mean' is for fractile input; with branches the mean is computed"
            )
        given_mean = read_hazard_curves(base / str(hz["mean"]), site_t, tail)[0]
        notes.append(
            "the given mean curve is drawn for reference; before/after statistics use the fractile branches"
        )
    if not branches:
        raise HazardInputError(f"{where}: no hazard curves read; expected at least one")
    rocks_raw = _req(raw, "rock", str(p), "[[rock]] tables")
    rocks: list[RockInput] = []
    cache: dict[Path, dict[str, Any]] = {}
    for i, r in enumerate(rocks_raw):
        w = f"{p} [[rock]] #{i + 1}"
        rid = str(_req(r, "id", w, "a rock id"))
        w = f"{p} [[rock]] {rid!r}"
        f = base / str(_req(r, "fragility", w, "an NRML fragility model or fragility CSV"))
        if f not in cache:
            cache[f] = read_fragility_model(f) if f.suffix.lower() == ".xml" else read_fragility_csv(f)
        fid = str(r.get("function", rid))
        if fid not in cache[f]:
            raise HazardInputError(f"{w}: key 'function': {fid!r} not in {f} (has {sorted(cache[f])})")
        dist = r.get("age_dist", "normal")
        try:
            age = Age(_pos(_req(r, "age", w, "the exposure age in years"), w, "age"),
                      _pos(r.get("age_sd", 0.0), w, "age_sd", allow_zero=True), dist)  # fmt: skip
        except HazardInputError as exc:
            raise HazardInputError(f"{w}: {exc}") from None
        rocks.append(RockInput(rid, cache[f][fid], age))
    return ConstrainConfig(
        str(raw.get("name", p.stem)), branches, rocks, joint, rate, qs, mode, p, notes, given_mean
    )
