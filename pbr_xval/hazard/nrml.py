"""Fragility functions in and out: OpenQuake NRML ``fragilityModel`` (0.5) and plain CSV.

NRML (OpenQuake manual, "Fragility Models")::

    <nrml xmlns="http://openquake.org/xmlns/nrml/0.5">
      <fragilityModel id="…" assetCategory="…" lossCategory="structural">
        <description>…</description>
        <limitStates>topple</limitStates>
        <fragilityFunction id="rock_A" format="continuous" shape="logncdf">
          <imls imt="PGA" minIML="…" maxIML="…"/>
          <params ls="topple" mean="…" stddev="…"/>
        </fragilityFunction>
        <fragilityFunction id="rock_A-discrete" format="discrete">
          <imls imt="PGA">0.1 0.2 …</imls>
          <poes ls="topple">0.0 0.01 …</poes>
        </fragilityFunction>
      </fragilityModel>
    </nrml>

* ``mean``/``stddev`` are the **linear** mean and standard deviation of the IM capacity, not
  (θ, β): ``mean = θ·exp(β²/2)``, ``stddev = mean·sqrt(exp(β²) − 1)``.
* IM values are in OpenQuake's units: g for PGA and SA(T), cm/s for PGV
  (:func:`pbr_xval.hazard.ims.oq_factor`); pbr-xval converts to and from SI.
* The continuous function's ``minIML``/``maxIML`` are θ·exp(∓3β) rounded outwards to 3
  significant digits (P_f from 0.0013 to 0.9987). OpenQuake does not integrate a continuous
  function: it discretises [minIML, maxIML] into ``continuous_fragility_discretization`` (job.ini,
  default 20) **linearly** spaced levels. A PBR fragility is narrow (β 0.2–0.5), so the span and
  the number of levels matter: θ·exp(∓5β) with 20 levels steps by 0.09 g around a 0.3 g median
  (β = 0.35). The model's ``<description>`` states the span and the
  ``continuous_fragility_discretization`` that makes every step ≤ θβ/5 (P_f changes by ≤ 8 % per
  step near the median) for the functions in the file (:func:`recommended_discretization`).
* The discrete form samples P_f at 25 levels from θ·exp(−3β) to θ·exp(3β) (steps of β/4 in ln IM)
  unless levels are given.
* Function ids allow letters, digits, ``-`` and ``_``: other characters of a rock id become ``_``.

The reader (:func:`read_fragility_model`) is written against the format, not against the writer:
it walks the tree by local tag names (any NRML namespace), reads every ``fragilityFunction``
and converts the limit state asked for (``topple`` by default, or the only one).

CSV (:func:`write_fragility_csv` / :func:`read_fragility_csv`): one row per function with
``id, im, unit, theta, beta, mean, stddev`` (SI), and the fit's intervals and counts when known.
"""

from __future__ import annotations

import csv
import math
import re
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from pbr_xval.hazard.fragility_functions import (
    DiscreteFragility,
    Fragility,
    LognormalFragility,
    lognormal_to_moments,
    moments_to_lognormal,
)
from pbr_xval.hazard.ims import HazardInputError, canonical_im, im_unit, oq_factor, oq_unit

__all__ = [
    "continuous_span",
    "read_fragility_csv",
    "read_fragility_model",
    "recommended_discretization",
    "write_fragility_csv",
    "write_fragility_model",
]

NRML_NS = "http://openquake.org/xmlns/nrml/0.5"


def _safe_id(s: str) -> str:
    return re.sub(r"[^A-Za-z0-9_\-]", "_", s)


def _g(v: float) -> str:
    return f"{v:.10g}"


def _round_sig(v: float, up: bool, sig: int = 3) -> float:
    """v rounded to ``sig`` significant digits, up (ceil) or down (floor)."""
    e = math.floor(math.log10(v)) - sig + 1
    f = 10.0**e
    return (math.ceil(v / f * (1 - 1e-12)) if up else math.floor(v / f * (1 + 1e-12))) * f


def continuous_span(f: LognormalFragility, k: float = 1.0) -> tuple[float, float]:
    """(minIML, maxIML) of a continuous function in the units of ``k`` (SI value / k): θ·e^∓3β,
    rounded outwards to 3 significant digits."""
    return (
        _round_sig(f.theta * math.exp(-3 * f.beta) / k, False),
        _round_sig(f.theta * math.exp(3 * f.beta) / k, True),
    )


def recommended_discretization(fragilities: Sequence[Fragility]) -> int:
    """OpenQuake's ``continuous_fragility_discretization`` that keeps every linear step of the
    continuous functions' [minIML, maxIML] at or below θβ/5 (at least 20, OpenQuake's default)."""
    n = 20
    for f in fragilities:
        if isinstance(f, LognormalFragility):
            lo, hi = continuous_span(f)
            n = max(n, math.ceil((hi - lo) / (f.theta * f.beta / 5.0)) + 1)
    return n


def write_fragility_model(
    path: str | Path,
    fragilities: Sequence[Fragility],
    fmt: str = "continuous",
    model_id: str = "pbr_xval",
    description: str = "Precariously balanced rock toppling fragility (pbr-xval)",
    limit_state: str = "topple",
    asset_category: str = "precarious_rocks",
    loss_category: str = "structural",
    levels: Any = None,
) -> Path:
    """Write fragility functions as an NRML 0.5 ``fragilityModel``, atomically.

    Parameters
    ----------
    path : path
    fragilities : list of Fragility
        Lognormal ones are written as ``fmt``; :class:`DiscreteFragility` always as discrete.
    fmt : ``continuous`` | ``discrete``
    levels : (k,) float, SI, optional
        IM levels of discrete functions (default 25 levels θ·exp(±3β)).
    """
    from pbr_xval.atomic import write_bytes_atomic

    if fmt not in ("continuous", "discrete"):
        raise ValueError(f"fmt {fmt!r}: expected 'continuous' or 'discrete'")
    ET.register_namespace("", NRML_NS)
    q = f"{{{NRML_NS}}}"
    root = ET.Element(q + "nrml")
    fm = ET.SubElement(root, q + "fragilityModel", id=_safe_id(model_id), assetCategory=asset_category,
                       lossCategory=loss_category)  # fmt: skip
    if fmt == "continuous" and any(isinstance(f, LognormalFragility) for f in fragilities):
        description += (
            f". Continuous logncdf functions span minIML–maxIML = θ·e^∓3β (P_f 0.0013–0.9987); OpenQuake "
            "discretises that span linearly into continuous_fragility_discretization levels (default 20): set "
            f"continuous_fragility_discretization = {recommended_discretization(fragilities)} in job.ini so that "
            "every step is at most θβ/5 for these functions"
        )
    ET.SubElement(fm, q + "description").text = description
    ET.SubElement(fm, q + "limitStates").text = limit_state
    for f in fragilities:
        k = oq_factor(f.im)
        if isinstance(f, LognormalFragility) and fmt == "continuous":
            ff = ET.SubElement(
                fm, q + "fragilityFunction", id=_safe_id(f.id), format="continuous", shape="logncdf"
            )
            lo, hi = continuous_span(f, k)
            ET.SubElement(ff, q + "imls", imt=f.im, minIML=_g(lo), maxIML=_g(hi))
            mean, sd = lognormal_to_moments(f.theta, f.beta)
            ET.SubElement(ff, q + "params", ls=limit_state, mean=_g(mean / k), stddev=_g(sd / k))
            continue
        if isinstance(f, DiscreteFragility):
            x, p = f.imls, f.poes
            attrs = {} if f.no_damage_limit is None else {"noDamageLimit": _g(f.no_damage_limit / k)}
        elif isinstance(f, LognormalFragility):
            x = (np.asarray(levels, float) if levels is not None
                 else f.theta * np.exp(f.beta * np.linspace(-3.0, 3.0, 25)))  # fmt: skip
            p, attrs = f.probability(x), {}
        else:
            raise TypeError(f"cannot write {type(f).__name__} as NRML")
        ff = ET.SubElement(fm, q + "fragilityFunction", id=_safe_id(f.id), format="discrete")
        ET.SubElement(ff, q + "imls", {"imt": f.im, **attrs}).text = " ".join(_g(v / k) for v in x)
        ET.SubElement(ff, q + "poes", ls=limit_state).text = " ".join(_g(float(v)) for v in p)
    ET.indent(root)
    data = ET.tostring(root, encoding="UTF-8", xml_declaration=True)
    return write_bytes_atomic(path, data)


def _local(tag: str) -> str:
    return tag.rsplit("}", 1)[-1]


def _child(el: ET.Element, name: str) -> ET.Element | None:
    return next((c for c in el if _local(c.tag) == name), None)


def _num(text: str | None, where: str, what: str) -> float:
    try:
        v = float(text)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise HazardInputError(f"{where}: {what} = {text!r}; expected a number") from None
    if not math.isfinite(v):
        raise HazardInputError(f"{where}: {what} = {text!r}; expected a finite number")
    return v


def read_fragility_model(path: str | Path, limit_state: str | None = None) -> dict[str, Fragility]:
    """Fragility functions of an NRML ``fragilityModel`` (0.4-style namespaces accepted), SI units.

    Returns
    -------
    dict
        function id → :class:`LognormalFragility` (continuous ``logncdf``) or
        :class:`DiscreteFragility` (discrete).
    """
    p = Path(path)
    if not p.is_file():
        raise HazardInputError(f"{p}: file not found; expected an NRML fragility model")
    if p.stat().st_size == 0:
        raise HazardInputError(f"{p}: empty file; expected an NRML fragility model")
    try:
        root = ET.parse(p).getroot()
    except ET.ParseError as exc:
        raise HazardInputError(
            f"{p}: not well-formed XML ({exc}); expected an NRML fragility model"
        ) from None
    fm = next((e for e in root.iter() if _local(e.tag) == "fragilityModel"), None)
    if fm is None:
        raise HazardInputError(f"{p}: no <fragilityModel> element; expected NRML 0.5 fragility model")
    ls_el = _child(fm, "limitStates")
    states = (ls_el.text or "").split() if ls_el is not None else []
    if not states:
        raise HazardInputError(f"{p}: <limitStates> missing or empty; expected the limit state names")
    if limit_state is None:
        limit_state = "topple" if "topple" in states else (states[0] if len(states) == 1 else None)
        if limit_state is None:
            raise HazardInputError(f"{p}: limit states {states}; expected 'topple' or choose one")
    elif limit_state not in states:
        raise HazardInputError(f"{p}: limit state {limit_state!r} not in <limitStates> {states}")
    out: dict[str, Fragility] = {}
    for ff in (e for e in fm if _local(e.tag) == "fragilityFunction"):
        fid = ff.get("id") or f"function{len(out)}"
        where = f"{p}: fragilityFunction {fid!r}"
        imls = _child(ff, "imls")
        if imls is None or imls.get("imt") is None:
            raise HazardInputError(f"{where}: <imls imt=…> missing; expected the intensity measure type")
        try:
            im = canonical_im(imls.get("imt", ""))
        except HazardInputError as exc:
            raise HazardInputError(f"{where}: field 'imt': {exc}") from None
        k = oq_factor(im)
        fmt = ff.get("format")
        if fmt == "continuous":
            if ff.get("shape", "logncdf") != "logncdf":
                raise HazardInputError(f"{where}: shape {ff.get('shape')!r}; expected 'logncdf'")
            par = next((c for c in ff if _local(c.tag) == "params" and c.get("ls") == limit_state), None)
            if par is None:
                raise HazardInputError(
                    f"{where}: no <params ls={limit_state!r}>; expected one per limit state"
                )
            mean = _num(par.get("mean"), where, "mean")
            sd = _num(par.get("stddev"), where, "stddev")
            if not (mean > 0 and sd > 0):
                raise HazardInputError(f"{where}: mean = {mean:g}, stddev = {sd:g}; expected both > 0")
            theta, beta = moments_to_lognormal(mean * k, sd * k)
            out[fid] = LognormalFragility(im, fid, theta=theta, beta=beta,
                                          meta={"source": str(p), "nrml_mean": mean, "nrml_stddev": sd})  # fmt: skip
        elif fmt == "discrete":
            levels = [_num(v, where, "imls") for v in (imls.text or "").split()]
            pe = next((c for c in ff if _local(c.tag) == "poes" and c.get("ls") == limit_state), None)
            if pe is None:
                raise HazardInputError(f"{where}: no <poes ls={limit_state!r}>; expected one per limit state")
            poes = [_num(v, where, "poes") for v in (pe.text or "").split()]
            ndl = imls.get("noDamageLimit")
            out[fid] = DiscreteFragility(im, fid, imls=np.array(levels) * k, poes=np.array(poes),
                                         no_damage_limit=None if ndl is None else _num(ndl, where, "noDamageLimit") * k)  # fmt: skip
        else:
            raise HazardInputError(f"{where}: format {fmt!r}; expected 'continuous' or 'discrete'")
    if not out:
        raise HazardInputError(f"{p}: no <fragilityFunction>; expected at least one")
    return out


_CSV_COLS = ["id", "im", "unit", "theta", "beta", "mean", "stddev", "theta_lo", "theta_hi", "beta_lo", "beta_hi",
             "ci_level", "n_runs", "n_toppled", "status", "source"]  # fmt: skip


def write_fragility_csv(path: str | Path, rows: list[dict[str, Any]]) -> Path:
    """Plain CSV of lognormal fragilities (SI units): one dict per function with at least ``id``,
    ``im``, ``theta``, ``beta``; ``unit``, ``mean`` and ``stddev`` are filled in."""
    import io

    from pbr_xval.atomic import write_text_atomic

    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=_CSV_COLS, extrasaction="ignore", lineterminator="\n")
    w.writeheader()
    for r in rows:
        r = dict(r)
        r["im"] = canonical_im(r["im"])
        r["unit"] = im_unit(r["im"])
        th, b = float(r["theta"]), float(r["beta"])
        if th > 0 and b >= 0 and math.isfinite(th) and math.isfinite(b):
            r["mean"], r["stddev"] = (_g(v) for v in lognormal_to_moments(th, b))
        w.writerow({k: (_g(v) if isinstance(v, float) else v) for k, v in r.items()})
    return write_text_atomic(path, buf.getvalue())


def read_fragility_csv(path: str | Path) -> dict[str, LognormalFragility]:
    """Lognormal fragilities from a CSV with columns ``id, im, unit, theta, beta`` (θ in ``unit``:
    the SI unit of the IM, or OpenQuake's g / cm/s) and, when present, the intervals ``theta_lo``,
    ``theta_hi``, ``beta_lo``, ``beta_hi``. Rows whose status is not ``ok`` are skipped."""
    p = Path(path)
    if not p.is_file():
        raise HazardInputError(f"{p}: file not found; expected a fragility CSV")
    rows = list(csv.DictReader(line for line in p.read_text(encoding="utf-8-sig").splitlines()
                               if line.strip() and not line.startswith("#")))  # fmt: skip
    if not rows:
        raise HazardInputError(
            f"{p}: empty file (no header or rows); expected columns id, im, unit, theta, beta"
        )
    missing = [c for c in ("id", "im", "unit", "theta", "beta") if c not in rows[0]]
    if missing:
        raise HazardInputError(f"{p}: column(s) {missing} missing; expected id, im, unit, theta, beta")
    out: dict[str, LognormalFragility] = {}
    for i, r in enumerate(rows, start=2):
        where = f"{p} line {i}"
        if r.get("status") not in (None, "", "ok"):
            continue
        try:
            im = canonical_im(r["im"])
        except HazardInputError as exc:
            raise HazardInputError(f"{where}: field 'im': {exc}") from None
        unit = r["unit"].strip()
        if unit == im_unit(im):
            k = 1.0
        elif unit == oq_unit(im):
            k = oq_factor(im)
        else:
            raise HazardInputError(
                f"{where}: field 'unit': {unit!r}; expected {im_unit(im)!r} or {oq_unit(im)!r} for {im}"
            )

        def opt(key: str, scale: float = 1.0, where: str = where, r: dict[str, Any] = r) -> float:
            v = (r.get(key) or "").strip()
            return _num(v, where, key) * scale if v and v.lower() != "nan" else math.nan

        try:
            out[r["id"]] = LognormalFragility(
                im, r["id"], theta=_num(r["theta"], where, "theta") * k, beta=_num(r["beta"], where, "beta"),
                theta_ci=(opt("theta_lo", k), opt("theta_hi", k)), beta_ci=(opt("beta_lo"), opt("beta_hi")),
                meta={"source": str(p), "ci_level": opt("ci_level")},
            )  # fmt: skip
        except HazardInputError as exc:
            raise HazardInputError(f"{where}: {exc}") from None
    return out
