"""The report in the field's units, the contribution plot's data and both headlines (issue 25, item 3)."""

from __future__ import annotations

import csv
import json
import math
import re

import numpy as np
import pytest

from pbr_xval.cli.hazard_impl import constrain_command
from pbr_xval.hazard.ims import G


class _Quiet:
    def __init__(self):
        self.lines = []

    def print(self, *a, **k):
        self.lines.append(" ".join(str(x) for x in a))


def _curve_csv(scale: float, im: str = "pga_g") -> str:
    x = np.geomspace(0.01, 4.0, 40)
    lam = scale * 1e-3 * (x / 0.1) ** -2.2 * np.exp(-0.15 * np.log(x / 0.1) ** 2)
    return f"{im},annual_rate\n" + "".join(f"{a:.8g},{b:.8g}\n" for a, b in zip(x, lam, strict=True))


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    d = tmp_path_factory.mktemp("units")
    for i, s in enumerate((0.5, 1.0, 2.0)):
        (d / f"h{i}.csv").write_text(_curve_csv(s))
    (d / "f.csv").write_text(
        "id,im,unit,theta,beta,theta_lo,theta_hi,beta_lo,beta_hi,ci_level\nA,PGA,g,0.35,0.3,0.3,0.42,0.22,0.45,0.95\n"
    )
    branches = "".join(
        f'[[hazard.branch]]\nfile = "h{i}.csv"\nweight = {w}\n' for i, w in enumerate((0.25, 0.5, 0.25))
    )
    (d / "c.toml").write_text(
        "rate_of_interest = 1e-4\nim_of_interest = 0.4\nfragility_draws = 128\n[hazard]\n"
        + branches
        + '[[rock]]\nid = "A"\nfragility = "f.csv"\nage = 15000.0\nage_sd = 2000.0\n'
    )
    con = _Quiet()
    assert constrain_command(d / "c.toml", d / "out", console=con) == 0
    return d / "out", con


def test_page_and_console_in_g_files_in_si(run):
    out, con = run
    page = (out / "index.html").read_text()
    tables = re.sub(r'<img src="[^"]*"', "", page)
    assert "m/s²" not in tables  # every IM on the page in g
    assert re.search(r"PGA of the mean hazard curve at λ = 0.0001 /yr</td><td>[0-9.]+ g</td>", tables)
    assert "θ = 0.35 g" in tables
    text = "\n".join(con.lines)
    assert "m/s" not in text and re.search(r"mean-curve PGA [0-9.]+ → [0-9.]+ g", text)
    # files: SI, unit in the column name
    head = next(ln for ln in (out / "curves.csv").read_text().splitlines() if not ln.startswith("#"))
    assert head.startswith("im_m_s2,")
    s = json.loads((out / "summary.json").read_text())
    h = s["headline_field_units"]
    assert h["field_unit"] == "g" and h["im_at_rate_before"] == pytest.approx(s["mean_im_before"] / G)


def test_both_headlines(run):
    out, con = run
    s = json.loads((out / "summary.json").read_text())
    # IM at the rate of interest, before and after; rate at the fixed IM (0.4 g, given), before and after
    assert s["mean_im_after"] < s["mean_im_before"]
    assert s["im_of_interest"] == pytest.approx(0.4 * G) and s["im_of_interest_given"]
    rows = list(
        csv.DictReader(ln for ln in (out / "curves.csv").read_text().splitlines() if not ln.startswith("#"))
    )
    x = np.array([float(r["im_m_s2"]) for r in rows])
    for tag in ("before", "after"):
        lam = np.array([float(r[f"mean_{tag}"]) for r in rows])
        ref = math.exp(np.interp(math.log(0.4 * G), np.log(x), np.log(lam)))
        assert s[f"mean_rate_{tag}_at_im"] == pytest.approx(ref, rel=1e-6)
    assert s["mean_rate_ratio_at_im"] == pytest.approx(
        s["mean_rate_after_at_im"] / s["mean_rate_before_at_im"]
    )
    assert s["mean_rate_ratio_at_im"] < 1
    text = "\n".join(con.lines)
    assert "at PGA = 0.4 g: mean annual rate" in text
    page = (out / "index.html").read_text()
    assert "mean annual rate of exceeding PGA = 0.4 g" in page


def test_contribution_integrates_to_the_toppling_rate(run):
    out, _ = run
    rows = list(
        csv.DictReader(
            ln for ln in (out / "contribution.csv").read_text().splitlines() if not ln.startswith("#")
        )
    )
    x = np.array([float(r["im_m_s2"]) for r in rows])
    dens = np.array([float(r["dnu_dlnim_A_before_per_yr"]) for r in rows])
    nu_grid = float(np.sum(0.5 * (dens[1:] + dens[:-1]) * np.diff(np.log(x))))
    b = list(csv.DictReader((out / "branches.csv").read_text().splitlines()))
    w = np.array([float(r["prior_weight"]) for r in b])
    nu = np.array([float(r["nu_A_per_yr"]) for r in b])
    # ν of the prior mean curve = Σ w_b ν_b; the grid (0.01–4 g) holds all but the tail above 4 g (P_f ≈ 1):
    # Σ w λ_b(4 g)
    tail = sum(
        wi * float(_curve_csv(s).splitlines()[-1].split(",")[1])
        for wi, s in zip(w, (0.5, 1.0, 2.0), strict=True)
    )
    assert nu_grid + tail == pytest.approx(float(w @ nu), rel=2e-3)
    s = json.loads((out / "summary.json").read_text())
    lo, hi = s["contribution_90"]["A"]
    assert lo < 0.35 * G < hi  # the central 90 % of ν brackets the median
    page = (out / "index.html").read_text()
    assert (
        "Contribution to each rock&#x27;s toppling rate" in page
        or "Contribution to each rock's toppling rate" in page
    )


def test_uncertainty_in_the_report(run):
    out, con = run
    s = json.loads((out / "summary.json").read_text())
    u = s["fragility_uncertainty"]["rocks"]["A"]
    assert u["method"] == "profile" and u["n_draws"] == 128
    assert u["ps_05"] < u["ps"] < u["ps_95"]
    sh = u["variance_shares"]
    assert sum(sh[k] for k in ("hazard", "fragility", "age", "interaction")) == pytest.approx(1.0)
    text = "\n".join(con.lines)
    assert "with the fragility's uncertainty" in text and "variance shares: hazard" in text
