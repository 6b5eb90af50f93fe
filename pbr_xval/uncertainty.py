"""Ensembles over what we do not know: the scenario's ``[uncertainty]`` table, sampled.

A scenario may carry an ``[uncertainty]`` table (``docs/scenarios.md``)::

    [uncertainty]
    members = 16                  # default 16
    seed = 0                      # default 0
    sampling = "sobol"            # sobol | lhs | random (scipy.stats.qmc)
    engines = ["mujoco", "pybullet"]   # the engines as a mixture (model uncertainty)
    engine_weights = [0.5, 0.5]        # optional
    "excitation.azimuth_deg" = { dist = "uniform", low = 0.0, high = 360.0 }
    "contact.friction_static" = { dist = "normal", mean = 0.6, sd = 0.1, low = 0.3, high = 0.9 }
    "rock.mass" = { dist = "lognormal", median = 353.8, beta = 0.05 }
    "model.collision" = { dist = "choice", values = ["hull", "coacd"], weights = [0.7, 0.3] }
    timestep = { dist = "choice", values = [1e-3, 5e-4] }   # engine-neutral: each member's engine

Every distribution is drawn by the inverse CDF of one column of a unit-cube design
(``scipy.stats.qmc.Sobol`` scrambled with ``seed``, ``LatinHypercube`` or
``numpy.random.default_rng(seed)``); the last column picks each member's engine through the
cumulative weights. Columns are the dotted keys in sorted order, then the engine, so member
``i`` of (scenario, members, seed, sampling) always gets the same values — Sobol and random
designs are sequences (member ``i`` does not depend on how many members are run), a Latin
hypercube is drawn for ``members`` rows at once.

A member's scenario is the base scenario with its values applied (``[uncertainty]`` removed):
:func:`member_scenario`. ``rock.mass`` replaces a ``rock.density`` (and vice versa).
"""

from __future__ import annotations

import copy
import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import numpy as np

    from pbr_xval.scenario import Scenario

__all__ = [
    "DIST_PARAMS",
    "Dist",
    "EnsembleSpec",
    "Member",
    "apply_values",
    "ensemble_spec",
    "jeffreys_interval",
    "member_scenario",
    "p_topple",
    "parse_uncertainty",
]

#: reserved keys of ``[uncertainty]`` (everything else is a dotted scenario key with a distribution)
RESERVED = ("members", "seed", "sampling", "engines", "engine_weights", "per_test")
SAMPLINGS = ("sobol", "lhs", "random")
#: distribution → (required parameters, optional parameters)
DIST_PARAMS: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = {
    "uniform": (("low", "high"), ()),
    "normal": (("mean", "sd"), ("low", "high")),
    "lognormal": (("median", "beta"), ()),
    "choice": (("values",), ("weights",)),
}
#: the engine-neutral key for each member's engine setting ``timestep``
TIMESTEP_KEY = "timestep"
#: unit-cube samples are kept inside [EPS, 1 − EPS] (an unbounded normal stays finite); the
#: scenario is validated at the values of both ends
EPS = 1e-6
MAX_MEMBERS = 1_000_000


class UncertaintyError(ValueError):
    """An invalid ``[uncertainty]`` table: one line per problem (file, key, found, expected)."""

    def __init__(self, lines: list[str]):
        self.lines = list(lines)
        super().__init__("\n".join(self.lines))


# --------------------------------------------------------------------------- distributions
@dataclass(frozen=True)
class Dist:
    """One uncertain scenario key: ``dist`` with its parameters (SI, as the key is written)."""

    key: str
    dist: str
    params: dict[str, Any]

    def normalised(self) -> dict[str, Any]:
        return {"dist": self.dist, **self.params}

    def ppf(self, u: float) -> Any:
        """The value at cumulative probability ``u`` (clipped to [EPS, 1 − EPS])."""
        u = min(max(float(u), EPS), 1.0 - EPS)
        p = self.params
        if self.dist == "uniform":
            return float(p["low"] + u * (p["high"] - p["low"]))
        if self.dist == "normal":
            from scipy import stats

            lo, hi = p.get("low"), p.get("high")
            if lo is None and hi is None:
                return float(stats.norm.ppf(u, loc=p["mean"], scale=p["sd"]))
            a = -math.inf if lo is None else (lo - p["mean"]) / p["sd"]
            b = math.inf if hi is None else (hi - p["mean"]) / p["sd"]
            v = float(stats.truncnorm.ppf(u, a, b, loc=p["mean"], scale=p["sd"]))
            return min(max(v, -math.inf if lo is None else lo), math.inf if hi is None else hi)
        if self.dist == "lognormal":
            from scipy import stats

            return float(p["median"] * math.exp(p["beta"] * float(stats.norm.ppf(u))))
        # choice
        return p["values"][_pick(u, p.get("weights"), len(p["values"]))]

    def extremes(self) -> list[Any]:
        """Values at both ends of what :meth:`ppf` can return (every value for a choice)."""
        p = self.params
        if self.dist == "choice":
            return list(p["values"])
        if self.dist == "uniform":
            return [p["low"], p["high"]]
        lo = p.get("low") if self.dist == "normal" else None
        hi = p.get("high") if self.dist == "normal" else None
        return [self.ppf(EPS) if lo is None else lo, self.ppf(1 - EPS) if hi is None else hi]


def _pick(u: float, weights: Sequence[float] | None, n: int) -> int:
    """Index ``j`` with F(j−1) ≤ u < F(j) for the cumulative normalised weights F."""
    w = [1.0] * n if weights is None else [float(x) for x in weights]
    total = sum(w)
    acc = 0.0
    for j, x in enumerate(w):
        acc += x / total
        if u < acc and x > 0:
            return j
    return max(j for j, x in enumerate(w) if x > 0)


# --------------------------------------------------------------------------- the table
@dataclass(frozen=True)
class Member:
    """One ensemble member: its index, engine and sampled values, and what reproduces them."""

    index: int
    engine: str | None
    values: dict[str, Any]
    seed: int
    sampling: str
    design_members: int

    def to_dict(self) -> dict[str, Any]:
        return {
            "member": self.index,
            "engine": self.engine,
            "values": dict(self.values),
            "seed": self.seed,
            "sampling": self.sampling,
            "design_members": self.design_members,
        }


@dataclass(frozen=True)
class EnsembleSpec:
    """A parsed ``[uncertainty]`` table."""

    dists: tuple[Dist, ...]
    engines: tuple[str, ...] = ()
    engine_weights: tuple[float, ...] | None = None
    members: int = 16
    seed: int = 0
    sampling: str = "sobol"
    per_test: bool = False
    _cache: dict[int, Any] = field(default_factory=dict, compare=False, repr=False)

    @property
    def keys(self) -> list[str]:
        return [d.key for d in self.dists]

    def normalised(self) -> dict[str, Any]:
        """Defaults filled in, dotted keys flat and sorted (the input to the scenario hash)."""
        d: dict[str, Any] = {
            "members": self.members,
            "seed": self.seed,
            "sampling": self.sampling,
            "per_test": self.per_test,
            "engines": list(self.engines),
            "engine_weights": None if self.engine_weights is None else list(self.engine_weights),
        }
        d["distributions"] = {x.key: x.normalised() for x in self.dists}
        return d

    def for_test(self, test: str) -> EnsembleSpec:
        """The spec whose members a campaign's test ``test`` runs: this one, or with ``per_test``
        its own design, seeded by SHA-256(seed, test) (the field mode: fresh draws for every test)."""
        if not self.per_test:
            return self
        import dataclasses
        import hashlib

        h = hashlib.sha256(f"{self.seed}\x00{test}".encode()).hexdigest()
        return dataclasses.replace(self, seed=int(h[:15], 16), per_test=False, _cache={})

    # ---------------------------------------------------------------- design
    def design(self, n: int) -> np.ndarray:
        """The (n, len(dists) + 1) unit-cube design; column −1 picks the engine."""
        import numpy as np
        from scipy.stats import qmc

        d = len(self.dists) + 1
        key = n if self.sampling == "lhs" else -1
        cached = self._cache.get(key)
        if cached is not None and cached.shape[0] >= n:
            return cached[:n]
        if self.sampling == "random":
            x = np.random.default_rng(self.seed).random((n, d))
        else:
            cls = qmc.Sobol if self.sampling == "sobol" else qmc.LatinHypercube
            try:
                eng = cls(d, scramble=True, rng=self.seed)
            except TypeError:  # scipy < 1.15
                eng = cls(d, scramble=True, seed=self.seed)
            with warnings.catch_warnings():  # Sobol: "balance properties" for n not a power of 2
                warnings.simplefilter("ignore", UserWarning)
                x = eng.random(n)
        self._cache.clear()
        self._cache[key] = x
        return x

    def member(self, i: int, *, members: int | None = None, engines: Sequence[str] | None = None) -> Member:
        """Member ``i`` (0-based) of a ``members``-member design (default: the table's)."""
        return self.sample(members=members, engines=engines, indices=[i])[0]

    def sample(
        self,
        *,
        members: int | None = None,
        engines: Sequence[str] | None = None,
        indices: Sequence[int] | None = None,
    ) -> list[Member]:
        """Members ``indices`` (default: all) of a ``members``-member design.

        ``engines`` restricts the mixture (each member's engine is drawn from the table's weights
        of the engines kept, equal weights for engines the table does not list); without engines
        in either place a member's engine is None (the caller names it).
        """
        n = int(members or self.members)
        idx = list(range(n)) if indices is None else [int(i) for i in indices]
        for i in idx:
            if not 0 <= i < n:
                raise ValueError(f"member {i}: expected 0 ≤ member < {n} (the ensemble's members)")
        rows = max(idx, default=-1) + 1
        x = self.design(n if self.sampling == "lhs" else rows)
        eng_list, weights = self.mixture(engines)
        out = []
        for i in idx:
            values = {dd.key: dd.ppf(x[i, j]) for j, dd in enumerate(self.dists)}
            e = eng_list[_pick(float(x[i, -1]), weights, len(eng_list))] if eng_list else None
            out.append(
                Member(
                    index=i, engine=e, values=values, seed=self.seed, sampling=self.sampling,
                    design_members=n,
                )
            )  # fmt: skip
        return out

    def mixture(self, engines: Sequence[str] | None = None) -> tuple[list[str], list[float] | None]:
        """(engines, weights) of the mixture, restricted to ``engines`` when given."""
        table = list(self.engines)
        tw = list(self.engine_weights) if self.engine_weights is not None else None
        if not engines:
            return table, tw
        eng = list(dict.fromkeys(engines))
        if tw is None or not all(e in table for e in eng):
            return eng, None
        w = [tw[table.index(e)] for e in eng]
        return eng, (w if sum(w) > 0 else None)


def p_topple(k: int, n: int) -> float:
    """P(topple) from ``k`` toppled of ``n`` members: the Jeffreys posterior mean (k + ½) / (n + 1) [–].

    The ensemble's members are draws from what we do not know; the quantity of interest is the
    share θ of the whole (infinite) ensemble that topples. Under the Jeffreys prior Beta(½, ½) —
    the prior of :func:`jeffreys_interval`, so the point and the interval come from one posterior
    Beta(k + ½, n − k + ½) — the posterior mean is the probability that one more member topples
    and the estimate of θ with the least expected squared error, i.e. the Bayes forecast under the
    Brier score. The raw share k / n is not: after 4 agreeing members (an adaptive ensemble's
    "decided" stop) it says 0 or 1, a certainty four runs cannot give (0 of 4: 0.1; 4 of 4: 0.9;
    0 of 16: 0.03). It lies inside the Jeffreys interval and on the same side of 0.5 as k / n (so
    F1 at P ≥ 0.5 is unchanged). ``n = 0`` gives NaN (no member ran: nothing is known).
    """
    if n <= 0:
        return math.nan
    return (k + 0.5) / (n + 1.0)


def jeffreys_interval(k: int, n: int, level: float = 0.95) -> tuple[float, float]:
    """Jeffreys interval of a binomial proportion: Beta(k + ½, n − k + ½) quantiles (α/2, 1 − α/2).

    Following Brown, Cai & DasGupta (2001), the lower end is 0 when k = 0 and the upper end 1
    when k = n. ``n = 0`` gives (0, 1).
    """
    from scipy import stats

    if n <= 0:
        return 0.0, 1.0
    a = (1 - level) / 2
    lo = 0.0 if k == 0 else float(stats.beta.ppf(a, k + 0.5, n - k + 0.5))
    hi = 1.0 if k == n else float(stats.beta.ppf(1 - a, k + 0.5, n - k + 0.5))
    return lo, hi


# --------------------------------------------------------------------------- parsing
def _flatten(table: Mapping[str, Any], prefix: str, out: dict[str, Any]) -> None:
    for k, v in table.items():
        key = f"{prefix}.{k}" if prefix else str(k)
        if not prefix and k in RESERVED and not (k == "engines" and isinstance(v, dict)):
            continue
        if isinstance(v, dict) and "dist" not in v:
            if not v:
                out[key] = v
            _flatten(v, key, out)
        else:
            out[key] = v


def _is_num(x: Any) -> bool:
    return isinstance(x, int | float) and not isinstance(x, bool) and math.isfinite(x)


def parse_uncertainty(table: Mapping[str, Any], where: str = "<scenario>") -> EnsembleSpec:
    """The ``[uncertainty]`` table as an :class:`EnsembleSpec` (parameters checked; keys not yet).

    Raises
    ------
    UncertaintyError
        one line per problem, naming ``uncertainty.<key>``, what was found and what was expected.
    """
    from pbr_xval.tomlio import key_line

    lines: list[str] = []

    def bad(key: str, msg: str, found: Any = None, expected: str | None = None) -> None:
        lines.append(key_line(where, f"uncertainty.{key}" if key else "uncertainty", msg, found, expected))

    if not isinstance(table, Mapping):
        raise UncertaintyError([key_line(where, "uncertainty", "expected a table", table)])
    members = table.get("members", 16)
    if not (isinstance(members, int) and not isinstance(members, bool) and 1 <= members <= MAX_MEMBERS):
        bad("members", "not a member count", members, f"an integer 1 … {MAX_MEMBERS}")
        members = 16
    seed = table.get("seed", 0)
    if not (isinstance(seed, int) and not isinstance(seed, bool) and 0 <= seed < 2**63):
        bad("seed", "not a seed", seed, "an integer ≥ 0")
        seed = 0
    sampling = table.get("sampling", "sobol")
    if sampling not in SAMPLINGS:
        bad("sampling", "unknown sampling", sampling, "one of " + ", ".join(SAMPLINGS))
        sampling = "sobol"
    engines_raw = table.get("engines", [])
    engines: list[str] = []
    if isinstance(engines_raw, dict):
        engines_raw = []
    if not (isinstance(engines_raw, list) and all(isinstance(e, str) for e in engines_raw)):
        bad("engines", "not a list of engine names", engines_raw, 'e.g. ["mujoco", "pybullet"]')
    else:
        from pbr_xval.registry import registered_names

        known = registered_names()
        for e in engines_raw:
            if e not in known:
                bad("engines", f"unknown engine {e!r}", None, "one of " + ", ".join(known))
        if len(set(engines_raw)) != len(engines_raw):
            bad("engines", "an engine is listed twice", engines_raw)
        engines = list(engines_raw)
    per_test = table.get("per_test", False)
    if not isinstance(per_test, bool):
        bad("per_test", "not true or false", per_test, "true (fresh draws for every test) or false")
        per_test = False
    ew = table.get("engine_weights")
    weights: tuple[float, ...] | None = None
    if ew is not None:
        if not engines:
            bad("engine_weights", "weights without 'engines'", ew, "an 'engines' list of the same length")
        elif not (
            isinstance(ew, list) and len(ew) == len(engines) and all(_is_num(x) and x >= 0 for x in ew)
        ):
            bad("engine_weights", "not one weight ≥ 0 per engine", ew, f"{len(engines)} numbers ≥ 0")
        elif sum(ew) <= 0:
            bad("engine_weights", "the weights sum to 0", ew, "at least one positive weight")
        else:
            weights = tuple(float(x) for x in ew)
    flat: dict[str, Any] = {}
    _flatten(table, "", flat)
    dists = []
    for key in sorted(flat):
        d = flat[key]
        if not isinstance(d, dict) or "dist" not in d:
            bad(
                key,
                "not a distribution",
                d,
                '{ dist = "uniform", low = …, high = … } (or normal, lognormal, choice)',
            )
            continue
        name = d["dist"]
        if name not in DIST_PARAMS:
            bad(key, "unknown distribution", name, "one of " + ", ".join(DIST_PARAMS))
            continue
        req, opt = DIST_PARAMS[name]
        extra = sorted(set(d) - {"dist", *req, *opt})
        if extra:
            bad(
                f"{key}.{extra[0]}",
                f"unknown parameter of a {name} distribution",
                None,
                "one of " + ", ".join((*req, *opt)),
            )
            continue
        missing = [p for p in req if p not in d]
        if missing:
            bad(
                f"{key}.{missing[0]}",
                f"missing parameter of a {name} distribution",
                None,
                ", ".join(req) + " required",
            )
            continue
        p = {k: d[k] for k in (*req, *opt) if k in d}
        problem = _check_params(name, p)
        if problem:
            bad(key, problem[0], problem[1], problem[2])
            continue
        dists.append(Dist(key=key, dist=name, params=p))
    if lines:
        raise UncertaintyError(lines)
    return EnsembleSpec(
        dists=tuple(dists), engines=tuple(engines), engine_weights=weights, members=int(members),
        seed=int(seed), sampling=str(sampling), per_test=per_test,
    )  # fmt: skip


def _check_params(name: str, p: dict[str, Any]) -> tuple[str, Any, str] | None:
    """(message, found, expected) of the first bad parameter, or None."""
    if name == "choice":
        v = p["values"]
        if not (isinstance(v, list) and v):
            return "'values' is not a non-empty list", v, "a list of values"
        w = p.get("weights")
        if w is not None:
            if not (isinstance(w, list) and len(w) == len(v) and all(_is_num(x) and x >= 0 for x in w)):
                return "'weights' is not one weight ≥ 0 per value", w, f"{len(v)} numbers ≥ 0"
            if sum(w) <= 0:
                return "the weights sum to 0", w, "at least one positive weight"
        return None
    for k, x in p.items():
        if not _is_num(x):
            return f"parameter {k!r} is not a finite number", x, "a number"
    if name == "uniform" and not p["low"] < p["high"]:
        return "low ≥ high", [p["low"], p["high"]], "low < high"
    if name == "normal":
        if p["sd"] <= 0:
            return "sd ≤ 0", p["sd"], "sd > 0"
        lo, hi = p.get("low"), p.get("high")
        if lo is not None and hi is not None and not lo < hi:
            return "low ≥ high", [lo, hi], "low < high (the truncation bounds)"
    if name == "lognormal":
        if p["median"] <= 0:
            return "median ≤ 0", p["median"], "median > 0"
        if p["beta"] <= 0:
            return "beta ≤ 0", p["beta"], "beta > 0 (the log standard deviation)"
    return None


def ensemble_spec(scn: Scenario) -> EnsembleSpec | None:
    """The scenario's parsed ``[uncertainty]`` (None when it has none)."""
    if scn.uncertainty is None:
        return None
    return parse_uncertainty(scn.uncertainty, str(scn._source) if scn._source else "<scenario>")


# --------------------------------------------------------------------------- applying values
def _engine_has_timestep(engine: str) -> bool:
    from pbr_xval.settings_spec import spec_for

    return spec_for(engine, "timestep") is not None


def apply_values(
    data: dict[str, Any], values: Mapping[str, Any], engine: str | None = None
) -> dict[str, Any]:
    """Set each dotted key of ``values`` in the scenario tables ``data`` (in place; returned).

    ``data`` must hold every table on the way (a full ``model_dump``). ``timestep`` goes to
    ``engines.<engine>.timestep`` for an engine that has that setting (analytical engines have
    none: the value is recorded, not applied); ``rock.mass`` replaces ``rock.density`` and
    vice versa.
    """
    for key, v in values.items():
        if key == TIMESTEP_KEY:
            if engine is not None and _engine_has_timestep(engine):
                data.setdefault("engines", {}).setdefault(engine, {})["timestep"] = v
            continue
        parts = key.split(".")
        node = data
        for p in parts[:-1]:
            if key.startswith("engines.") and p not in node:
                node[p] = {}
            if not isinstance(node.get(p), dict):
                raise KeyError(f"no table {p!r} on the way to key {key!r}")
            node = node[p]
        node[parts[-1]] = copy.deepcopy(v)
        if key == "rock.mass":
            node.pop("density", None)
        elif key == "rock.density":
            node.pop("mass", None)
    return data


def base_tables(scn: Scenario) -> dict[str, Any]:
    """Every table of the scenario, defaults filled in, ``[uncertainty]`` removed."""
    d = scn.model_dump(mode="json")
    d.pop("uncertainty", None)
    return d


def member_name(base: str, index: int) -> str:
    return f"{base}__m{index:04d}"


def member_scenario(scn: Scenario, member: Member, engine: str | None = None) -> Scenario:
    """The member's own scenario: the base scenario with its values applied, no ``[uncertainty]``."""
    d = apply_values(base_tables(scn), member.values, engine or member.engine)
    d["name"] = member_name(scn.name, member.index)
    return scn.from_tables(d)


# --------------------------------------------------------------------------- key checks
def check_keys(scn: Scenario, spec: EnsembleSpec, where: str) -> list[str]:
    """One line per uncertain key that is not a scenario key or whose values make it invalid."""
    from pydantic import BaseModel

    from pbr_xval.errors import ScenarioError
    from pbr_xval.registry import registered_names
    from pbr_xval.settings_spec import check_settings
    from pbr_xval.tomlio import key_line

    lines: list[str] = []
    base = base_tables(scn)
    if TIMESTEP_KEY in spec.keys:
        both = [k for k in spec.keys if k.startswith("engines.") and k.endswith(".timestep")]
        if both:
            lines.append(
                key_line(where, f"uncertainty.{both[0]}", "the engine-neutral 'timestep' is uncertain too",
                         None, "one of the two (timestep applies to every member's engine)")
            )  # fmt: skip
    for d in spec.dists:
        k = d.key
        parts = k.split(".")
        if k == TIMESTEP_KEY:
            for val in d.extremes():
                if not _is_num(val) or val <= 0:
                    lines.append(key_line(where, f"uncertainty.{k}", "not a timestep", val, "a time > 0 s"))
                    break
            continue
        if parts[0] == "engines":
            known = registered_names()
            if len(parts) != 3:
                lines.append(
                    key_line(
                        where,
                        f"uncertainty.{k}",
                        "not an engine setting key",
                        None,
                        "engines.<engine>.<setting>",
                    )
                )
                continue
            if parts[1] not in known:
                lines.append(
                    key_line(
                        where,
                        f"uncertainty.{k}",
                        f"unknown engine {parts[1]!r}",
                        None,
                        "one of " + ", ".join(known),
                    )
                )
                continue
            for val in d.extremes():
                problems = check_settings(
                    parts[1], {parts[2]: val}, complete=False, where=f"{where}: key 'uncertainty.{k}'"
                )
                if problems:
                    lines.append(problems[0])
                    break
            continue
        node: Any = scn
        ok = True
        for i, p in enumerate(parts):
            fields = type(node).model_fields if isinstance(node, BaseModel) else {}
            if p not in fields or p == "uncertainty" or (i == 0 and p in ("name", "description")):
                expected = ", ".join(sorted(f for f in fields if f != "uncertainty")) or "a scenario key"
                lines.append(
                    key_line(
                        where,
                        f"uncertainty.{k}",
                        f"not a scenario key (no {p!r})",
                        None,
                        f"one of: {expected}",
                    )
                )
                ok = False
                break
            node = getattr(node, p)
        if not ok:
            continue
        if isinstance(node, BaseModel):
            lines.append(
                key_line(
                    where, f"uncertainty.{k}", "is a table, not a value", None, "a dotted key to a value"
                )
            )
            continue
        for val in d.extremes():
            trial = apply_values(copy.deepcopy(base), {k: val})
            try:
                scn.from_tables(trial)
            except ScenarioError as exc:
                first = str(exc).splitlines()[0].removeprefix(f"{where}: ")
                lines.append(
                    key_line(
                        where, f"uncertainty.{k}", f"the value {val!r} makes the scenario invalid: {first}"
                    )
                )
                break
    return lines
