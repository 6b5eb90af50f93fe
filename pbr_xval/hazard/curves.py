"""Site hazard curves: annual exceedance rate λ(im) of an intensity measure, and their readers.

A :class:`HazardCurve` holds IM levels (SI: m/s² for PGA/SA, m/s for PGV) and annual rates of
exceedance (1/yr), validated: levels strictly increasing and > 0, rates finite, ≥ 0 and
non-increasing. Between levels λ is interpolated as a power law (linear in ln λ – ln x);
a segment ending at λ = 0 is linear in λ. Above the last level the curve either continues
the last segment's power law (``tail="powerlaw"``, the default) or stops (``tail="cut"``:
λ = 0 above the last level, so all the rate λ(x_n) sits at x_n — a lower bound on any
integral of a non-decreasing fragility).

Readers (each bad input gives one :class:`~pbr_xval.hazard.ims.HazardInputError` line naming
the file and field):

* plain CSV — two columns, ``<im>_<unit>`` and ``annual_rate`` (1/yr); ``<im>`` is ``pga``,
  ``pgv`` or ``sa(T)``, ``<unit>`` is ``m_s2`` or ``g`` (PGA, SA), ``m_s`` or ``cm_s`` (PGV).
  ``#`` lines are comments. :func:`write_curve_csv` writes this format.
* OpenQuake CSV (``hazard_curve-mean-PGA_<calc>.csv``, ``quantile_curve-0.05-PGA_…``,
  ``hazard_curve-rlz-000-PGA_…``): a ``#`` header with ``investigation_time`` and ``imt``,
  columns ``lon,lat[,depth],poe-<iml>…``, IMLs in OpenQuake units (g, cm/s).
* OpenQuake NRML ``hazardCurves`` XML (0.4 or 0.5): ``IMT`` (+ ``saPeriod``),
  ``investigationTime``, ``<IMLs>`` and one ``<hazardCurve>`` per site with ``<poEs>``.

OpenQuake gives probabilities of exceedance ``poe`` over the investigation time ``t``; with
Poisson occurrence the annual rate is ``λ = −ln(1 − poe)/t``. Levels with ``poe = 1`` carry no
rate information (λ ≥ any value) and are dropped (noted in :attr:`HazardCurve.notes`).
"""

from __future__ import annotations

import csv
import math
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from pbr_xval.hazard.ims import HazardInputError, canonical_im, oq_factor

__all__ = [
    "HazardCurve",
    "poe_to_rate",
    "rate_to_poe",
    "read_hazard_curve",
    "read_hazard_curves",
    "write_curve_csv",
    "write_oq_csv",
]


def poe_to_rate(poe: Any, investigation_time: float) -> np.ndarray:
    """Annual rate (1/yr) from a probability of exceedance in ``investigation_time`` years
    (Poisson occurrence): ``λ = −ln(1 − poe)/t``."""
    return -np.log1p(-np.asarray(poe, float)) / float(investigation_time)


def rate_to_poe(rate: Any, investigation_time: float) -> np.ndarray:
    """Probability of at least one exceedance in ``investigation_time`` years (Poisson)."""
    return -np.expm1(-np.asarray(rate, float) * float(investigation_time))


@dataclass
class HazardCurve:
    """Annual exceedance rate of an IM at a site.

    Attributes
    ----------
    im : str
        ``PGA``, ``PGV`` or ``SA(T)``.
    levels : (n,) float
        IM levels, SI units, strictly increasing, > 0.
    rates : (n,) float
        Annual exceedance rates λ(levels), 1/yr, non-increasing, ≥ 0.
    name : str
        Branch or statistic name.
    weight : float
        Logic-tree weight (branches) — 1 for a single curve.
    tail : str
        ``powerlaw`` or ``cut`` (see the module docstring).
    """

    im: str
    levels: Any
    rates: Any
    name: str = "hazard"
    weight: float = 1.0
    tail: str = "powerlaw"
    source: str = ""
    notes: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        where = self.source or f"hazard curve {self.name!r}"
        self.im = canonical_im(self.im)
        x = np.asarray(self.levels, float)
        r = np.asarray(self.rates, float)
        if x.ndim != 1 or x.shape != r.shape:
            raise HazardInputError(
                f"{where}: levels/rates of shapes {x.shape}/{r.shape}; expected two equal 1-D lists"
            )
        if x.size < 2:
            raise HazardInputError(f"{where}: {x.size} IM level(s); expected at least 2")
        if not np.all(np.isfinite(x) & (x > 0)):
            raise HazardInputError(f"{where}: field 'levels': {x.tolist()}; expected finite IM levels > 0")
        if not np.all(np.diff(x) > 0):
            i = int(np.argmin(np.diff(x)))
            raise HazardInputError(
                f"{where}: field 'levels': {x[i]:g} then {x[i + 1]:g}; expected strictly increasing IM levels"
            )
        if not np.all(np.isfinite(r)):
            raise HazardInputError(
                f"{where}: field 'rates': non-finite value(s); expected finite annual rates"
            )
        if np.any(r < 0):
            i = int(np.argmin(r))
            raise HazardInputError(
                f"{where}: field 'rates': negative rate {r[i]:g} at IM {x[i]:g}; expected ≥ 0"
            )
        d = np.diff(r)
        if np.any(d > 1e-12 * np.maximum(r[:-1], 1e-300)):
            i = int(np.argmax(d))
            raise HazardInputError(
                f"{where}: field 'rates': rate rises from {r[i]:g} at IM {x[i]:g} to {r[i + 1]:g} at {x[i + 1]:g};"
                " expected a non-increasing exceedance curve"
            )
        if r[0] <= 0:
            raise HazardInputError(
                f"{where}: field 'rates': all rates are 0; expected a positive rate at the lowest level"
            )
        if self.tail not in ("powerlaw", "cut"):
            raise HazardInputError(f"{where}: tail {self.tail!r}; expected 'powerlaw' or 'cut'")
        if not (self.weight >= 0 and math.isfinite(self.weight)):
            raise HazardInputError(f"{where}: weight {self.weight!r}; expected ≥ 0")
        self.levels, self.rates = x, r

    # ------------------------------------------------------------------ evaluation
    @property
    def _last_positive(self) -> int:
        return int(np.nonzero(self.rates > 0)[0][-1])

    def tail_exponent(self) -> float:
        """k of the power-law tail λ ∝ x^−k (the last positive segment's slope); nan if none."""
        j = self._last_positive
        if j == 0 or j < self.rates.size - 1:
            return math.nan  # curve reaches 0: no tail
        x, r = self.levels, self.rates
        return float(-(math.log(r[j]) - math.log(r[j - 1])) / (math.log(x[j]) - math.log(x[j - 1])))

    def rate(self, x: Any) -> np.ndarray:
        """λ(x), 1/yr; x : (m,) float, SI. Below the first level: λ(x_1) (events there are unknown)."""
        x = np.atleast_1d(np.asarray(x, float))
        lv, rt = self.levels, self.rates
        out = np.empty_like(x)
        j = self._last_positive
        lx = np.log(np.maximum(x, 1e-300))
        # power-law part on positive rates
        pos = rt > 0
        llv, lrt = np.log(lv[pos]), np.log(rt[pos])
        out[:] = np.exp(np.interp(lx, llv, lrt))
        # a segment ending in zero: linear in λ
        if j < rt.size - 1:
            seg = (x > lv[j]) & (x <= lv[j + 1])
            out[seg] = rt[j] * (lv[j + 1] - x[seg]) / (lv[j + 1] - lv[j])
            out[x > lv[j + 1]] = 0.0
        else:
            above = x > lv[-1]
            if self.tail == "cut":
                out[above] = 0.0
            else:
                k = self.tail_exponent()
                out[above] = rt[-1] * (x[above] / lv[-1]) ** (-k)
        return out

    def im_at_rate(self, rate: float) -> float:
        """IM (SI) at which λ = rate (log-log inverse interpolation; power-law tail beyond); nan if
        the rate is above λ(x_1) or unreachable."""
        lv, rt = self.levels, self.rates
        if rate > rt[0] or rate <= 0:
            return math.nan
        pos = rt > 0
        lr, ll = np.log(rt[pos])[::-1], np.log(lv[pos])[::-1]
        if rate >= rt[pos][-1]:
            return float(np.exp(np.interp(math.log(rate), lr, ll)))
        j = self._last_positive
        if j < rt.size - 1:  # the segment down to λ = 0 is linear in λ
            return float(lv[j] + (lv[j + 1] - lv[j]) * (1.0 - rate / rt[j]))
        k = self.tail_exponent()
        if self.tail == "cut" or not (k > 0):
            return math.nan
        return float(lv[-1] * (rate / rt[-1]) ** (-1.0 / k))

    def scaled(self, factor: float) -> HazardCurve:
        """The same curve with IM levels multiplied by ``factor`` (unit conversion)."""
        return HazardCurve(self.im, self.levels * factor, self.rates.copy(), self.name, self.weight, self.tail,
                           self.source, list(self.notes))  # fmt: skip


# ---------------------------------------------------------------------- readers
_UNIT_SUFFIX = {"m_s2": 1.0, "g": 9.80665, "m_s": 1.0, "cm_s": 0.01}
_ACC_UNITS, _VEL_UNITS = ("m_s2", "g"), ("m_s", "cm_s")
_IM_COL = re.compile(r"^\s*(pga|pgv|sa\s*\(\s*[0-9.eE+-]+\s*\))\s*_\s*(m_s2|g|m_s|cm_s)\s*$", re.IGNORECASE)


def _parse_im_column(name: str, where: str) -> tuple[str, float]:
    m = _IM_COL.match(name)
    if not m:
        raise HazardInputError(
            f"{where}: IM column {name!r}: unknown IM or unit; expected pga_m_s2, pga_g, pgv_m_s, pgv_cm_s,"
            " sa(T)_m_s2 or sa(T)_g"
        )
    im = canonical_im(m.group(1))
    unit = m.group(2).lower()
    if (im == "PGV") != (unit in _VEL_UNITS):
        ok = "m_s or cm_s" if im == "PGV" else "m_s2 or g"
        raise HazardInputError(f"{where}: IM column {name!r}: unit {unit!r} does not fit {im}; expected {ok}")
    return im, _UNIT_SUFFIX[unit]


def _rows(path: Path) -> tuple[list[str], list[list[str]], list[str]]:
    """(comment lines, data rows) of a CSV; error if empty."""
    try:
        text = path.read_text(encoding="utf-8-sig")
    except OSError as exc:
        raise HazardInputError(
            f"{path}: cannot read ({exc.strerror or exc}); expected a readable file"
        ) from None
    lines = text.splitlines()
    comments = [ln for ln in lines if ln.lstrip().startswith("#")]
    body = [ln for ln in lines if ln.strip() and not ln.lstrip().startswith("#")]
    if not body:
        raise HazardInputError(f"{path}: empty file (no header or data rows); expected a hazard-curve CSV")
    rows = list(csv.reader(body))
    return comments, rows, lines


def _float(s: str, where: str, field_: str) -> float:
    try:
        return float(s)
    except ValueError:
        raise HazardInputError(f"{where}: field {field_!r}: {s!r} is not a number") from None


def _read_plain_csv(path: Path, rows: list[list[str]], tail: str) -> HazardCurve:
    header = [h.strip() for h in rows[0]]
    where = str(path)
    if len(header) < 2:
        raise HazardInputError(f"{where}: header {header}; expected two columns '<im>_<unit>,annual_rate'")
    im, factor = _parse_im_column(header[0], where)
    if header[1].lower() not in ("annual_rate", "annual_rate_per_yr", "rate"):
        raise HazardInputError(f"{where}: column {header[1]!r}; expected 'annual_rate' (1/yr)")
    data = rows[1:]
    if not data:
        raise HazardInputError(f"{where}: no data rows under the header; expected IM levels and annual rates")
    x = [_float(r[0], f"{where} line {i + 2}", header[0]) for i, r in enumerate(data)]
    lam = [
        _float(r[1], f"{where} line {i + 2}", header[1]) if len(r) > 1 else math.nan
        for i, r in enumerate(data)
    ]
    return HazardCurve(im, np.array(x) * factor, np.array(lam), name=path.stem, tail=tail, source=f"{where}")


_OQ_META = re.compile(r"(\w+)\s*=\s*('[^']*'|\"[^\"]*\"|[^,\"]+)")


def _oq_meta(comments: list[str]) -> dict[str, str]:
    meta: dict[str, str] = {}
    for c in comments:
        for k, v in _OQ_META.findall(c.lstrip("#").replace('"', " ")):
            meta[k] = v.strip().strip("'\"")
    return meta


def _pick_site(coords: list[tuple[float, float]], site: tuple[float, float] | None, where: str) -> int:
    if site is None:
        if len(coords) != 1:
            raise HazardInputError(f"{where}: {len(coords)} sites; expected one, or give site=(lon, lat)")
        return 0
    d = [math.hypot(lo - site[0], la - site[1]) for lo, la in coords]
    return int(np.argmin(d))


def _from_poes(
    im: str, imls: np.ndarray, poes: np.ndarray, t_inv: float, name: str, where: str, tail: str
) -> HazardCurve:
    if not (t_inv > 0 and math.isfinite(t_inv)):
        raise HazardInputError(f"{where}: field 'investigation_time': {t_inv!r}; expected > 0 years")
    if np.any(~np.isfinite(poes)) or np.any(poes < 0) or np.any(poes > 1):
        raise HazardInputError(
            f"{where}: field 'poes': values outside [0, 1]; expected probabilities of exceedance"
        )
    keep = poes < 1.0 - 1e-12
    notes = []
    if not keep.all():
        notes.append(f"{int((~keep).sum())} level(s) with poe = 1 dropped (no rate information)")
    if keep.sum() < 2:
        raise HazardInputError(
            f"{where}: field 'poes': fewer than 2 levels with poe < 1; expected a usable curve"
        )
    rates = poe_to_rate(poes[keep], t_inv)
    c = HazardCurve(im, imls[keep] * oq_factor(im), rates, name=name, tail=tail, source=where, notes=notes)
    c.notes.append(f"Poisson: λ = −ln(1 − poe)/{t_inv:g} yr; IMLs converted from OpenQuake units")
    return c


def _read_oq_csv(path: Path, comments: list[str], rows: list[list[str]], site: Any, tail: str) -> HazardCurve:
    where = str(path)
    meta = _oq_meta(comments)
    if "imt" not in meta:
        raise HazardInputError(
            f"{where}: header comment: no imt=...; expected OpenQuake's '# ... imt='PGA'' line"
        )
    if "investigation_time" not in meta:
        raise HazardInputError(f"{where}: header comment: no investigation_time=...; expected it in years")
    im = _im(meta["imt"], None, where, "imt")
    header = [h.strip() for h in rows[0]]
    pcols = [i for i, h in enumerate(header) if h.startswith("poe-")]
    if not pcols or "lon" not in header or "lat" not in header:
        raise HazardInputError(f"{where}: header {header[:4]}…; expected lon, lat and poe-<iml> columns")
    imls = np.array([_float(header[i][4:], where, header[i]) for i in pcols])
    data = rows[1:]
    if not data:
        raise HazardInputError(f"{where}: no site rows under the header; expected one row per site")
    ilo, ila = header.index("lon"), header.index("lat")
    coords = [(_float(r[ilo], where, "lon"), _float(r[ila], where, "lat")) for r in data]
    k = _pick_site(coords, site, where)
    poes = np.array([_float(data[k][i], f"{where} line {k + 2 + len(comments)}", header[i]) for i in pcols])
    kind = meta.get("kind", path.stem)
    t_inv = _float(meta["investigation_time"], where, "investigation_time")
    return _from_poes(im, imls, poes, t_inv, kind, where, tail)


def _im(name: str, period: float | None, where: str, field_: str) -> str:
    try:
        return canonical_im(name, period)
    except HazardInputError as exc:
        raise HazardInputError(f"{where}: field {field_!r}: {exc}") from None


def _local(tag: str) -> str:
    return tag.rsplit("}", 1)[-1]


def _read_nrml_curves(path: Path, site: Any, tail: str) -> list[HazardCurve]:
    where = str(path)
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as exc:
        raise HazardInputError(f"{where}: not well-formed XML ({exc}); expected NRML hazardCurves") from None
    blocks = [e for e in root.iter() if _local(e.tag) == "hazardCurves"]
    if not blocks:
        raise HazardInputError(f"{where}: no <hazardCurves> element; expected NRML hazard curves")
    out = []
    for b in blocks:
        imt = b.get("IMT")
        if imt is None:
            raise HazardInputError(
                f"{where}: <hazardCurves> attribute 'IMT' missing; expected PGA, PGV or SA"
            )
        per = b.get("saPeriod")
        im = _im(imt, _float(per, where, "saPeriod") if per is not None else None, where, "IMT")
        t_inv = _float(b.get("investigationTime", "nan"), where, "investigationTime")
        iml_el = next((e for e in b if _local(e.tag) == "IMLs"), None)
        if iml_el is None or not (iml_el.text or "").split():
            raise HazardInputError(f"{where}: <IMLs> missing or empty; expected the IM levels")
        imls = np.array([_float(s, where, "IMLs") for s in (iml_el.text or "").split()])
        curves = [e for e in b if _local(e.tag) == "hazardCurve"]
        if not curves:
            raise HazardInputError(f"{where}: no <hazardCurve> under <hazardCurves>; expected one per site")
        coords, poes_all = [], []
        for c in curves:
            pos = next((e for e in c.iter() if _local(e.tag) == "pos"), None)
            xy = (
                [float(v) for v in (pos.text or "nan nan").split()[:2]]
                if pos is not None
                else [math.nan, math.nan]
            )
            coords.append((xy[0], xy[1]))
            pe = next((e for e in c if _local(e.tag) == "poEs"), None)
            if pe is None:
                raise HazardInputError(
                    f"{where}: <hazardCurve> without <poEs>; expected probabilities of exceedance"
                )
            poes_all.append(np.array([_float(s, where, "poEs") for s in (pe.text or "").split()]))
        k = _pick_site(coords, site, where)
        poes = poes_all[k]
        if poes.size != imls.size:
            raise HazardInputError(
                f"{where}: field 'poEs': {poes.size} values for {imls.size} IMLs; expected equal"
            )
        stat = b.get("statistics")
        name = (
            (f"quantile-{b.get('quantileValue')}" if stat == "quantile" else stat)
            or "|".join(v for v in (b.get("sourceModelTreePath"), b.get("gsimTreePath")) if v)
            or path.stem
        )
        out.append(_from_poes(im, imls, poes, t_inv, name, where, tail))
    return out


def read_hazard_curves(
    path: str | Path, site: tuple[float, float] | None = None, tail: str = "powerlaw"
) -> list[HazardCurve]:
    """Every hazard curve in a file (plain CSV, OpenQuake CSV or NRML XML), for one site.

    Parameters
    ----------
    path : path
    site : (lon, lat), optional
        Needed when the file holds several sites (the nearest is taken).
    tail : ``powerlaw`` | ``cut``

    Returns
    -------
    list of HazardCurve, IM levels in SI units.
    """
    p = Path(path)
    if not p.is_file():
        raise HazardInputError(f"{p}: file not found; expected a hazard-curve file (CSV or NRML XML)")
    if p.suffix.lower() == ".xml":
        return _read_nrml_curves(p, site, tail)
    comments, rows, _ = _rows(p)
    if any("investigation_time" in c for c in comments) or any(h.strip().startswith("poe-") for h in rows[0]):
        return [_read_oq_csv(p, comments, rows, site, tail)]
    return [_read_plain_csv(p, rows, tail)]


def read_hazard_curve(
    path: str | Path, site: tuple[float, float] | None = None, tail: str = "powerlaw"
) -> HazardCurve:
    """The one hazard curve of a file (see :func:`read_hazard_curves`)."""
    cs = read_hazard_curves(path, site, tail)
    if len(cs) != 1:
        raise HazardInputError(f"{path}: {len(cs)} <hazardCurves> blocks; expected one")
    return cs[0]


def write_curve_csv(curve: HazardCurve, path: str | Path) -> Path:
    """Plain CSV in SI units (``<im>_m_s2|m_s,annual_rate``), written atomically."""
    from pbr_xval.atomic import write_text_atomic

    unit = "m_s" if curve.im == "PGV" else "m_s2"
    lines = [f"# hazard curve {curve.name}: annual exceedance rate (1/yr) of {curve.im}",
             f"{curve.im.lower()}_{unit},annual_rate"]  # fmt: skip
    lines += [f"{x:.10g},{r:.10g}" for x, r in zip(curve.levels, curve.rates, strict=True)]
    return write_text_atomic(path, "\n".join(lines) + "\n")


def write_oq_csv(
    curve: HazardCurve, path: str | Path, investigation_time: float = 50.0, kind: str = "mean",
    lon: float = 0.0, lat: float = 0.0,
) -> Path:  # fmt: skip
    """An OpenQuake-style hazard-curve CSV (poe over ``investigation_time``, IMLs in g or cm/s)."""
    from pbr_xval.atomic import write_text_atomic

    f = oq_factor(curve.im)
    poes = rate_to_poe(curve.rates, investigation_time)
    head = (f"#,,,,,\"generated_by='pbr-xval', kind='{kind}', investigation_time={investigation_time!r}, "
            f"imt='{curve.im}'\"")  # fmt: skip
    cols = "lon,lat,depth," + ",".join(f"poe-{x / f:.8g}" for x in curve.levels)
    row = f"{lon:.5f},{lat:.5f},0.00000," + ",".join(f"{p:.6E}" for p in poes)
    return write_text_atomic(path, "\n".join([head, cols, row]) + "\n")
