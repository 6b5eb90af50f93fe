"""The ``pbr-xval constrain`` input file (TOML): hazard branches or fractiles, rocks, ages.

::

    name = "my-site"
    joint = "independent"          # or "shared-events"
    rate_of_interest = 1e-4        # 1/yr, where the report compares IMs before and after
    quantiles = [0.05, 0.5, 0.95]  # needs at least 2 branches
    normalize_weights = false      # true: rescale branch weights that do not sum to 1 (else an error)
    allow_truncated_curve = false  # true: run a curve that starts where P_f > truncation_p_max (warned)
    truncation_p_max = 0.01        # largest P_f accepted at a curve's lowest level
    tail_tolerance = 0.01          # 'cut' tail: largest (1 − P_f(x_n))·λ(x_n)·T̄ accepted
    im_of_interest = 0.3           # IM of the second headline (rate before/after), g (PGA, SA) or cm/s (PGV)
    fragility_draws = 256          # draws per rock from the fit's intervals (0: fragility taken as known)
    seed = 0

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
    fragility_uncertainty = "profile"   # profile (from the intervals; default when present) | ensemble | none
    # ensemble = "fragility/members.csv"  # member fragilities (CSV rows: id, im, unit, theta, beta), one draw each
    # vector_coef = [b0, b1, b2]          # Φ(b0 + b1 ln PGA[m/s²] + b2 ln PGV/PGA[s]) instead of 'fragility',
                                          # with [hazard.pgv_pga] median_s, sigma_ln, slope (0), ref_pga_g (1)

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

_TOP = {"name", "joint", "rate_of_interest", "quantiles", "hazard", "rock", "description", "normalize_weights",
        "allow_truncated_curve", "truncation_p_max", "tail_tolerance", "im_of_interest", "fragility_draws", "seed"}  # fmt: skip
_WEIGHT_TOL = 1e-6


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
    allow_truncated: bool = False
    truncation_p_max: float = 0.01
    tail_tolerance: float = 0.01
    im_of_interest: float | None = None  # SI
    #: rock id → FragilityDraws (pbr_xval.hazard.fragility_draws), for rocks whose fragility is drawn
    draws: dict[str, Any] = field(default_factory=dict)
    pgv_pga: Any = None


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


def _read_branches(
    hz: dict[str, Any],
    where: str,
    p: Path,
    base: Path,
    site_t: tuple[float, float] | None,
    tail: str,
    notes: list[str],
) -> tuple[list[HazardCurve], str]:
    """The hazard branches of ``[hazard]`` (``branch`` or ``quantile`` tables) and the mode read."""
    branches: list[HazardCurve] = []
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
        try:
            branches = branches_from_quantiles([curves[i] for i in order], [qv[i] for i in order])
        except HazardInputError as exc:
            raise HazardInputError(f"{where}: {exc}") from None
        notes.append("hazard given as fractile curves: each is a branch weighted by the interval between midpoints "
                     "to its neighbouring fractiles (an approximation of the distribution)")  # fmt: skip
    else:
        raise HazardInputError(f"{where}: no [[hazard.branch]] or [[hazard.quantile]]; expected one of them")
    return branches, mode


def _check_weights(
    hz: dict[str, Any], branches: list[HazardCurve], where: str, flags: dict[str, bool], notes: list[str]
) -> None:
    """Branch weights: none given (equal weights), all given and summing to 1 (or rescaled)."""
    given = [("weight" in b) for b in hz["branch"]]
    wsum = sum(c.weight for c in branches)
    if not any(given):
        for c in branches:
            c.weight = 1.0 / len(branches)
        if len(branches) > 1:
            notes.append(f"no branch weights given: {len(branches)} branches weighted equally")
    elif not all(given):
        raise HazardInputError(
            f"{where}: weights given for {sum(given)} of {len(given)} branches; expected a weight on every branch"
        )
    elif abs(wsum - 1.0) > _WEIGHT_TOL:
        if not flags["normalize_weights"]:
            raise HazardInputError(
                f"{where}: branch weights sum to {wsum:.6g}; expected 1 (within {_WEIGHT_TOL:g}), "
                "or set normalize_weights = true to rescale them"
            )
        notes.append(f"branch weights summed to {wsum:.6g}; rescaled to 1 (normalize_weights = true)")


def _pgv_pga(hz: dict[str, Any], where: str, notes: list[str]) -> Any:
    """The ``[hazard.pgv_pga]`` model of PGV/PGA given PGA (vector fragilities), or None."""
    pgv_pga = None
    if "pgv_pga" in hz:
        from pbr_xval.hazard.ims import G
        from pbr_xval.hazard.vector import PgvPgaModel

        m = hz["pgv_pga"]
        w = f"{where} [hazard.pgv_pga]"
        bad = sorted(set(m) - {"median_s", "sigma_ln", "slope", "ref_pga_g", "source"})
        if bad:
            raise HazardInputError(
                f"{w}: unknown key(s) {bad}; expected median_s, sigma_ln, slope, ref_pga_g, source"
            )
        try:
            pgv_pga = PgvPgaModel(_pos(_req(m, "median_s", w, "the median PGV/PGA in s"), w, "median_s"),
                                  _pos(_req(m, "sigma_ln", w, "the ln standard deviation"), w, "sigma_ln", True),
                                  float(m.get("slope", 0.0)), _pos(m.get("ref_pga_g", 1.0), w, "ref_pga_g") * G)  # fmt: skip
        except HazardInputError as exc:
            raise HazardInputError(f"{w}: {exc}") from None
        notes.append("PGV/PGA given PGA (stated model for the vector fragilities): " + pgv_pga.describe()
                     + (f" — {m['source']}" if "source" in m else ""))  # fmt: skip
    return pgv_pga


def _read_rocks(
    raw: dict[str, Any], p: Path, base: Path, pgv_pga: Any, n_draws: int, seed: int
) -> tuple[list[RockInput], dict[str, Any]]:
    """The ``[[rock]]`` tables: each rock's fragility (and its draws) and exposure age."""
    from pbr_xval.hazard.nrml import read_fragility_csv, read_fragility_model

    rocks_raw = _req(raw, "rock", str(p), "[[rock]] tables")
    rocks: list[RockInput] = []
    cache: dict[Path, dict[str, Any]] = {}
    draws: dict[str, Any] = {}
    for i, r in enumerate(rocks_raw):
        w = f"{p} [[rock]] #{i + 1}"
        rid = str(_req(r, "id", w, "a rock id"))
        w = f"{p} [[rock]] {rid!r}"
        bad = sorted(set(r) - _ROCK_KEYS)
        if bad:
            raise HazardInputError(f"{w}: unknown key(s) {bad}; expected some of {sorted(_ROCK_KEYS)}")
        unc = r.get("fragility_uncertainty")
        if unc not in (None, "profile", "ensemble", "none"):
            raise HazardInputError(
                f"{w}: key 'fragility_uncertainty': {unc!r}; expected profile, ensemble or none"
            )
        if "vector_coef" in r:
            frag = _vector(r, w, pgv_pga)
            if unc not in (None, "none"):
                raise HazardInputError(
                    f"{w}: key 'fragility_uncertainty': {unc!r}; a vector fragility is taken as fitted"
                )
        else:
            f = base / str(_req(r, "fragility", w, "an NRML fragility model or fragility CSV"))
            if f not in cache:
                cache[f] = read_fragility_model(f) if f.suffix.lower() == ".xml" else read_fragility_csv(f)
            fid = str(r.get("function", rid))
            if fid not in cache[f]:
                raise HazardInputError(f"{w}: key 'function': {fid!r} not in {f} (has {sorted(cache[f])})")
            frag = cache[f][fid]
            d = _draws(r, w, base, frag, unc, n_draws, seed + i)
            if d is not None:
                draws[rid] = d
        dist = r.get("age_dist", "normal")
        try:
            age = Age(_pos(_req(r, "age", w, "the exposure age in years"), w, "age"),
                      _pos(r.get("age_sd", 0.0), w, "age_sd", allow_zero=True), dist)  # fmt: skip
        except HazardInputError as exc:
            raise HazardInputError(f"{w}: {exc}") from None
        rocks.append(RockInput(rid, frag, age))
    return rocks, draws


def load_config(path: str | Path) -> ConstrainConfig:
    """Read and validate a constrain TOML; reads every hazard and fragility file it names."""

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
    flags = {}
    for key in ("normalize_weights", "allow_truncated_curve"):
        v = raw.get(key, False)
        if not isinstance(v, bool):
            raise HazardInputError(f"{p}: key '{key}': {v!r}; expected true or false")
        flags[key] = v
    p_max = _pos(raw.get("truncation_p_max", 0.01), str(p), "truncation_p_max")
    tail_tol = _pos(raw.get("tail_tolerance", 0.01), str(p), "tail_tolerance")
    n_draws = raw.get("fragility_draws", 256)
    if not (isinstance(n_draws, int) and not isinstance(n_draws, bool) and 0 <= n_draws <= 100000):
        raise HazardInputError(
            f"{p}: key 'fragility_draws': {n_draws!r}; expected an integer 0–100000 (0: none)"
        )
    seed = raw.get("seed", 0)
    if not (isinstance(seed, int) and not isinstance(seed, bool) and seed >= 0):
        raise HazardInputError(f"{p}: key 'seed': {seed!r}; expected an integer ≥ 0")
    hz = _req(raw, "hazard", str(p), "a [hazard] table")
    where = f"{p} [hazard]"
    tail = hz.get("tail", "powerlaw")
    if tail not in ("powerlaw", "cut"):
        raise HazardInputError(f"{where}: key 'tail': {tail!r}; expected 'powerlaw' or 'cut'")
    site = hz.get("site")
    site_t = (float(site[0]), float(site[1])) if site else None
    notes: list[str] = []
    branches, mode = _read_branches(hz, where, p, base, site_t, tail, notes)
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
    if mode == "branches":
        _check_weights(hz, branches, where, flags, notes)
    if len(branches) == 1 and "quantiles" in raw:
        raise HazardInputError(
            f"{p}: key 'quantiles': {list(qs)} with 1 hazard branch; fractiles need at least 2 branches "
            "(remove 'quantiles' to run a single curve)"
        )
    pgv_pga = _pgv_pga(hz, where, notes)
    rocks, draws = _read_rocks(raw, p, base, pgv_pga, n_draws, seed)
    if "description" in raw:
        notes.insert(0, str(raw["description"]))
    im_int = None
    if "im_of_interest" in raw:
        from pbr_xval.hazard.ims import oq_factor, oq_unit

        im0 = branches[0].im
        im_int = _pos(raw["im_of_interest"], str(p), f"im_of_interest (in {oq_unit(im0)})") * oq_factor(im0)
    return ConstrainConfig(
        str(raw.get("name", p.stem)), branches, rocks, joint, rate, qs, mode, p, notes, given_mean,
        flags["allow_truncated_curve"], p_max, tail_tol, im_int, draws, pgv_pga,
    )  # fmt: skip


_ROCK_KEYS = {"id", "fragility", "function", "age", "age_sd", "age_dist", "fragility_uncertainty", "ensemble",
              "vector_coef", "description"}  # fmt: skip


def _vector(r: dict[str, Any], w: str, model: Any) -> Any:
    from pbr_xval.hazard.vector import VectorFragility

    coef = r["vector_coef"]
    if not (isinstance(coef, list) and len(coef) == 3):
        raise HazardInputError(f"{w}: key 'vector_coef': {coef!r}; expected [b0, b1, b2]")
    try:
        b = tuple(float(v) for v in coef)
    except (TypeError, ValueError):
        raise HazardInputError(f"{w}: key 'vector_coef': {coef!r}; expected three numbers") from None
    if "fragility" in r:
        raise HazardInputError(f"{w}: both 'fragility' and 'vector_coef'; expected one of them")
    if model is None:
        raise HazardInputError(
            f"{w}: key 'vector_coef' needs a PGV/PGA model; expected [hazard.pgv_pga] with median_s and sigma_ln "
            "(docs/hazard.md: the vector fragility)"
        )
    try:
        return VectorFragility(str(r["id"]), b).on_pga(model)  # type: ignore[arg-type]
    except HazardInputError as exc:
        raise HazardInputError(f"{w}: {exc}") from None


def _draws_csv(f: Path, w: str, frag: Any) -> dict[str, Any] | None:
    """Members from a bootstrap-draws CSV of ``pbr-xval fragility --ensemble``
    (``ensemble_fragility_<im>_draws.csv``: ``draw, theta_m_s2 | theta_m_s, beta``), or None when
    the file has another layout."""
    import csv

    from pbr_xval.hazard.fragility_functions import LognormalFragility

    head = f.read_text(encoding="utf-8-sig").splitlines()[:1]
    cols = [c.strip() for c in head[0].split(",")] if head else []
    tcol = next((c for c in cols if c in ("theta_m_s2", "theta_m_s")), None)
    if tcol is None or "beta" not in cols or "id" in cols:
        return None
    if (tcol == "theta_m_s") != (frag.im == "PGV"):
        raise HazardInputError(
            f"{w}: key 'ensemble': {f.name} has {tcol}; the rock's fragility is on {frag.im}"
        )
    out: dict[str, Any] = {}
    for i, row in enumerate(csv.DictReader(f.read_text(encoding="utf-8-sig").splitlines()), start=2):
        try:
            th, be = float(row[tcol]), float(row["beta"])
        except (TypeError, ValueError):
            raise HazardInputError(f"{w}: key 'ensemble': {f} line {i}: θ or β not a number") from None
        fid = f"{frag.id}#{row.get('draw', i - 2)}"
        try:
            out[fid] = LognormalFragility(frag.im, fid, theta=th, beta=be)
        except HazardInputError as exc:
            raise HazardInputError(f"{w}: key 'ensemble': {f} line {i}: {exc}") from None
    return out


def _draws(r: dict[str, Any], w: str, base: Path, frag: Any, unc: str | None, n: int, seed: int) -> Any:
    """The rock's fragility draws (or None: the fragility taken as known)."""
    from pbr_xval.hazard.fragility_draws import FragilityDraws, draws_from_profile
    from pbr_xval.hazard.fragility_functions import LognormalFragility

    if "ensemble" in r:
        if unc not in (None, "ensemble"):
            raise HazardInputError(
                f"{w}: key 'ensemble' with fragility_uncertainty = {unc!r}; expected 'ensemble'"
            )
        from pbr_xval.hazard.nrml import read_fragility_csv, read_fragility_model

        f = base / str(r["ensemble"])
        if not f.is_file():
            raise HazardInputError(f"{w}: key 'ensemble': {f}: file not found; expected member fragilities")
        boot = None if f.suffix.lower() == ".xml" else _draws_csv(f, w, frag)
        if boot is not None:
            if len(boot) < 2:
                raise HazardInputError(f"{w}: key 'ensemble': {len(boot)} draw in {f}; expected at least 2")
            note = f"{len(boot)} bootstrap draws (θ, β) of pbr-xval fragility --ensemble ({f.name})"
            return FragilityDraws(str(r["id"]), list(boot.values()), "bootstrap", note)
        mem = read_fragility_model(f) if f.suffix.lower() == ".xml" else read_fragility_csv(f)
        bad = [m.id for m in mem.values() if m.im != frag.im]
        if bad:
            raise HazardInputError(
                f"{w}: key 'ensemble': members {bad[:3]} not on {frag.im}; expected the rock's IM"
            )
        if len(mem) < 2:
            raise HazardInputError(f"{w}: key 'ensemble': {len(mem)} member in {f}; expected at least 2")
        return FragilityDraws(
            str(r["id"]), list(mem.values()), "ensemble", f"{len(mem)} ensemble members ({f.name})"
        )
    if unc == "ensemble":
        raise HazardInputError(
            f"{w}: fragility_uncertainty = 'ensemble' needs key 'ensemble' (a member file)"
        )
    if unc == "none" or n == 0:
        return None
    finite = isinstance(frag, LognormalFragility) and all(
        math.isfinite(v) and v > 0 for v in (*frag.theta_ci, *frag.beta_ci)
    )
    if not finite:
        if unc == "profile":
            raise HazardInputError(
                f"{w}: fragility_uncertainty = 'profile' but the fragility has no finite θ and β intervals "
                "(a fragility CSV from pbr-xval fragility carries them)"
            )
        return None
    try:
        return draws_from_profile(frag, n, seed)
    except HazardInputError as exc:
        raise HazardInputError(f"{w}: {exc}") from None
