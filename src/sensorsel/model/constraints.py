"""What a suite must satisfy besides its score: money, resources, mounting slots, owned and banned sensors.

A user's request is a :class:`Constraints` (plain data, recorded in every result it produced). Bound
to a library and a budget it becomes a :class:`FeasibleSet`: every limit as a row of a packing
system ``A x <= b`` over the library's sensors (x_i = 1 when sensor i is in the suite), plus the
sensors the suite must hold and those it may not. Every selector asks the feasible set what fits;
none ever returns a suite outside it.

Rows (all of ``A`` is >= 0, so removing a sensor never breaks a limit):

- ``budget``: each sensor's price [$]; an owned sensor (``require`` with ``owned``) costs 0.
- one row per ``--limit RESOURCE=VALUE``: what each sensor draws of the resource the library
  declares (``power_w``, ``mass_kg``, ``data_rate_mbps``), against the limit.
- one row per mounting slot of the library (unless ``slots`` is False): 1 for each sensor the slot
  counts, against its capacity.
- ``sensors`` (``max_sensors``): 1 for every sensor.

**What "cost" means to the cost-aware rules** (``cost-benefit``, ``marginal``): a sensor's
*dollar-equivalent cost*, its price plus, for each resource limit, the share of that limit it uses
valued at the whole budget (a radar drawing 6.6 W of a 100 W limit, under a $110,000 budget, costs
$1,493 + 6.6 % x $110,000). Without resource limits it is exactly the price, so those rules weigh
the price alone. Slots and ``max_sensors`` are capacities, not costs: they only decide what fits.
"""

from __future__ import annotations

import hashlib
import json
import math
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from sensorsel.errors import InputError
from sensorsel.model.library import SensorLibrary, resource_unit

__all__ = ["BUDGET_ONLY", "Constraints", "FeasibleSet", "RowUse", "feasible_set", "parse_limit", "recorded"]

#: Slack on every row, relative to its limit: a suite whose total equals a limit fits despite round-off.
REL_SLACK = 1e-9
_LIMIT = re.compile(r"^\s*([a-z][a-z0-9_]*)\s*=\s*(\S+)\s*$")


@dataclass(frozen=True)
class Constraints:
    """A request's limits besides the budget (the CLI's ``--limit``, ``--include``, ``--owned``,
    ``--exclude``, ``--max-sensors``, ``--no-slots``).

    Attributes:
        limits: (resource name, limit) pairs, sorted by name, e.g. (("power_w", 100.0),); the
            resource's unit is the library's (W, kg, Mbit/s).
        slots: honour the library's mounting slots.
        require: ids of sensors every suite must hold (sorted).
        owned: the required sensors are already bought: their price does not count against the budget
            (their power, mass and data rate do).
        exclude: ids of sensors no suite may hold (sorted).
        max_sensors: most sensors in a suite, or None.
        library_digest: sha256 of the resources and slots these limits were checked against (set by
            :func:`feasible_set`; a result is only re-used on a library with the same digest).
    """

    limits: tuple[tuple[str, float], ...] = ()
    slots: bool = True
    require: tuple[str, ...] = ()
    owned: bool = False
    exclude: tuple[str, ...] = ()
    max_sensors: int | None = None
    library_digest: str = ""

    @classmethod
    def of(
        cls,
        *,
        limits: Iterable[tuple[str, float]] | dict[str, float] = (),
        slots: bool = True,
        require: Iterable[str] = (),
        owned: bool = False,
        exclude: Iterable[str] = (),
        max_sensors: int | None = None,
    ) -> Constraints:
        """Constraints in canonical form (sorted, each resource once); values are checked by
        :func:`feasible_set` against a library."""
        pairs = list(limits.items()) if isinstance(limits, dict) else list(limits)
        names = [n for n, _ in pairs]
        for n in names:
            if names.count(n) > 1:
                raise InputError(f"--limit {n}: given twice; give each resource once")
        return cls(
            tuple(sorted((str(n), float(v)) for n, v in pairs)),
            bool(slots),
            tuple(sorted(set(require))),
            bool(owned),
            tuple(sorted(set(exclude))),
            max_sensors,
        )

    @property
    def is_default(self) -> bool:
        """No limit besides the budget (slots aside: they come from the library)."""
        return not (self.limits or self.require or self.exclude or self.max_sensors is not None)

    def describe(self) -> str:
        """One line for a result's header: ``power_w <= 100 W; slots; require LRL-roof (owned)``."""
        parts = [f"{n} <= {_fmt(v)}{' ' + resource_unit(n) if resource_unit(n) else ''}" for n, v in self.limits]
        parts.append("slots" if self.slots else "no slots")
        if self.require:
            parts.append(f"require {','.join(self.require)}{' (owned)' if self.owned else ''}")
        if self.exclude:
            parts.append(f"exclude {','.join(self.exclude)}")
        if self.max_sensors is not None:
            parts.append(f"at most {self.max_sensors} sensors")
        return "; ".join(parts)


#: The paper's problem: the budget is the only limit (the library's slots ignored).
BUDGET_ONLY = Constraints(slots=False)


def recorded(constraints: Constraints | None) -> Constraints:
    """The constraints a result was computed under: a result records None when the budget was its
    only limit (so None here is :data:`BUDGET_ONLY`, whatever slots the library has)."""
    return BUDGET_ONLY if constraints is None else constraints


def parse_limit(text: str, option: str = "--limit") -> tuple[str, float]:
    """``"power_w=100"`` -> ("power_w", 100.0); an :class:`InputError` naming ``option`` otherwise."""
    m = _LIMIT.match(text)
    if not m:
        raise InputError(f"{option} {text!r}: expected RESOURCE=VALUE, e.g. {option} power_w=100")
    name, value = m.group(1), m.group(2).replace(",", "")
    try:
        v = float(value)
    except ValueError:
        raise InputError(f"{option} {text!r}: {m.group(2)!r} is not a number") from None
    if not math.isfinite(v) or v < 0:
        raise InputError(f"{option} {text!r}: the limit must be a finite number >= 0")
    return name, v


@dataclass(frozen=True)
class RowUse:
    """How much of one limit a suite uses (for result tables).

    Attributes:
        name: the row ("budget", "power_w", "3 o'clock radar", "sensors").
        used: the suite's total.
        limit: the limit.
        unit: "$", "W", "kg", "Mbit/s", "" (counts).
    """

    name: str
    used: float
    limit: float
    unit: str


class FeasibleSet:
    """The suites a request allows, as a packing system over a library's sensors.

    Attributes:
        library: the sensors.
        budget_usd: the budget [$].
        constraints: the request, with ``library_digest`` filled in.
        names: (m,) row names; row 0 is the budget.
        units: (m,) row units.
        A: (m, n) what each sensor uses of each row (>= 0).
        b: (m,) the limits.
        required: library positions every suite holds (sorted).
        excluded: library positions no suite holds.
        cost: (n,) the dollar-equivalent cost the cost-aware rules use (module docstring).

    Raises:
        InputError: an unknown resource or sensor id, a sensor both required and excluded, or
            required sensors that break a limit (naming the limit, the total and the option).
    """

    def __init__(self, library: SensorLibrary, budget_usd: float, constraints: Constraints | None = None) -> None:
        c = constraints or Constraints()
        n = len(library)
        self.library = library
        self.budget_usd = float(budget_usd)
        self.required = _positions(library, c.require, "--include")
        excluded = _positions(library, c.exclude, "--exclude")
        both = sorted(set(self.required) & set(excluded))
        if both:
            raise InputError(f"--include and --exclude both name {', '.join(library.ids[i] for i in both)}")
        self.excluded = frozenset(excluded)
        price = library.costs.copy()
        if c.owned:
            price[list(self.required)] = 0.0
        names, units, rows, limits = ["budget"], ["$"], [price], [self.budget_usd]
        declared = library.resource_names
        for name, limit in c.limits:
            if name not in declared:
                known = ", ".join(declared) if declared else "none (add `resources:` to the models)"
                raise InputError(
                    f"--limit {name}={_fmt(limit)}: the library {library.source} declares no resource "
                    f"{name!r}; it declares: {known}"
                )
            lacking = sorted({s.model.code for s in library.sensors if name not in dict(s.model.resources)})
            if lacking:
                raise InputError(
                    f"--limit {name}={_fmt(limit)}: in the library {library.source}, model(s) "
                    f"{', '.join(lacking)} declare no {name} (add it under their `resources:`; 0 is allowed)"
                )
            names.append(name)
            units.append(resource_unit(name))
            rows.append(library.resource(name))
            limits.append(float(limit))
        if c.slots:
            for slot in library.slots:
                row = np.zeros(n)
                row[list(slot.members)] = 1.0
                names.append(slot.label)
                units.append("")
                rows.append(row)
                limits.append(float(slot.capacity))
        if c.max_sensors is not None:
            if isinstance(c.max_sensors, bool) or not isinstance(c.max_sensors, int) or c.max_sensors < 1:
                raise InputError(f"--max-sensors must be a whole number >= 1, got {c.max_sensors!r}")
            names.append("sensors")
            units.append("")
            rows.append(np.ones(n))
            limits.append(float(c.max_sensors))
        self.names = tuple(names)
        self.units = tuple(units)
        self.A = np.vstack(rows) if n else np.zeros((len(rows), 0))
        self.b = np.asarray(limits, dtype=float)
        self._slack = REL_SLACK * np.maximum(1.0, np.abs(self.b))
        self.n_resource_rows = 1 + len(c.limits)  # budget + resources: the rows that are costs
        self.constraints = Constraints(
            c.limits, c.slots, c.require, c.owned, c.exclude, c.max_sensors, _library_digest(library)
        )
        self.cost = self._dollar_equivalent(price)
        self._check_required()

    def __repr__(self) -> str:
        return f"FeasibleSet(${self.budget_usd:,.0f}; {self.constraints.describe()})"

    @property
    def plain(self) -> bool:
        """The paper's problem: the budget is the only row and nothing is required or excluded
        (whatever was asked: e.g. slots on a library without any). Every selector runs its
        budget-only path, unchanged, when this holds."""
        return self.only_budget and not self.required and not self.excluded

    @property
    def record(self) -> Constraints | None:
        """The constraints a result records: None when :attr:`plain`, else :attr:`constraints`."""
        return None if self.plain else self.constraints

    @property
    def only_budget(self) -> bool:
        """True when the budget is the only row (the paper's problem: a single knapsack)."""
        return len(self.names) == 1

    def usage(self, suite: Iterable[int]) -> np.ndarray:
        """(m,) what ``suite`` uses of each row."""
        idx = list(suite)
        return self.A[:, idx].sum(axis=1) if idx else np.zeros(len(self.b))

    def fits(self, suite: Iterable[int]) -> bool:
        """Whether ``suite`` is allowed: every row within its limit, required sensors in, excluded out."""
        s = set(suite)
        return (
            set(self.required) <= s and not (s & self.excluded) and bool(np.all(self.usage(s) <= self.b + self._slack))
        )

    def addable(self, used: np.ndarray) -> np.ndarray:
        """(n,) bool: the sensors that fit on top of a suite using ``used`` of each row (excluded
        sensors never do; sensors already in the suite are the caller's to mask)."""
        ok = np.all(self.A <= (self.b + self._slack - used)[:, None], axis=0)
        if self.excluded:
            ok[list(self.excluded)] = False
        return ok

    def room(self, used: np.ndarray) -> np.ndarray:
        """(m,) what is left of each row after ``used``."""
        return self.b - used

    def rows_used(self, suite: Iterable[int]) -> tuple[RowUse, ...]:
        """Each row's total for ``suite`` against its limit."""
        u = self.usage(suite)
        return tuple(
            RowUse(n, float(x), float(lim), unit) for n, x, lim, unit in zip(self.names, u, self.b, self.units)
        )

    def violations(self, suite: Iterable[int]) -> list[str]:
        """What ``suite`` breaks, in words (empty when it fits)."""
        s = set(suite)
        out = [f"misses required {self.library.ids[i]}" for i in self.required if i not in s]
        out += [f"holds excluded {self.library.ids[i]}" for i in sorted(s & self.excluded)]
        u = self.usage(s)
        for k in np.flatnonzero(u > self.b + self._slack):
            out.append(
                f"{self.names[k]} {_amount(u[k], self.units[k])} above its limit {_amount(self.b[k], self.units[k])}"
            )
        return out

    def why_nothing_fits(self, used: np.ndarray, candidates: np.ndarray) -> str:
        """Which limits stop the remaining ``candidates`` (bool (n,)) from fitting, for a stop reason
        ("12 by the budget ($17 left); 30 by a full mounting slot")."""
        left = self.b + self._slack - used
        over = self.A[:, candidates] > left[:, None]
        first = over & (np.cumsum(over, axis=0) == 1)  # each sensor counted at the first limit it breaks
        parts = []
        n_slots = 0
        for k in range(len(self.b)):
            count = int(first[k].sum())
            if not count:
                continue
            if self._is_slot(k):
                n_slots += count
            else:
                parts.append(
                    f"{count} by {self.names[k]} ({_amount(max(self.b[k] - used[k], 0.0), self.units[k])} left)"
                )
        if n_slots:
            parts.append(f"{n_slots} by a full mounting slot")
        excluded = int(np.sum(candidates[list(self.excluded)])) if self.excluded else 0
        if excluded:
            parts.append(f"{excluded} excluded")
        return "; ".join(parts)

    def _is_slot(self, k: int) -> bool:
        return k >= self.n_resource_rows and self.names[k] != "sensors"

    def _dollar_equivalent(self, price: np.ndarray) -> np.ndarray:
        cost = price.astype(float).copy()
        for k in range(1, self.n_resource_rows):
            share = np.divide(self.A[k], self.b[k], out=np.where(self.A[k] > 0, np.inf, 0.0), where=self.b[k] > 0)
            cost = cost + self.budget_usd * share
        return cost

    def _check_required(self) -> None:
        if not self.required:
            return
        u = self.usage(self.required)
        bad = np.flatnonzero(u > self.b + self._slack)
        if len(bad):
            k = int(bad[0])
            ids = ",".join(self.library.ids[i] for i in self.required)
            option = {"budget": "--budget", "sensors": "--max-sensors"}.get(self.names[k])
            what = option or (f"--limit {self.names[k]}" if k < self.n_resource_rows else f"the slot {self.names[k]}")
            raise InputError(
                f"--include {ids}: the required sensors use {_amount(u[k], self.units[k])} of "
                f"{self.names[k]}, above {what} ({_amount(self.b[k], self.units[k])}): no suite can hold them"
            )


def feasible_set(library: SensorLibrary, budget_usd: float, constraints: Constraints | None = None) -> FeasibleSet:
    """The :class:`FeasibleSet` of a request (see its Raises)."""
    return FeasibleSet(library, budget_usd, constraints)


def _positions(library: SensorLibrary, ids: Sequence[str], option: str) -> tuple[int, ...]:
    out = []
    for sid in ids:
        try:
            out.append(library.position(sid))
        except InputError:
            raise InputError(f"{option}: unknown sensor id {sid!r} (see `sensorsel library` for the ids)") from None
    return tuple(sorted(set(out)))


def _library_digest(library: SensorLibrary) -> str:
    """sha256 of what constraints read from a library: each sensor's resources, and the slots."""
    doc = {
        "resources": [list(s.model.resources) for s in library.sensors],
        "slots": [[sl.place, sl.kind, sl.capacity, list(sl.members)] for sl in library.slots],
    }
    return hashlib.sha256(json.dumps(doc, sort_keys=True).encode()).hexdigest()


def _fmt(v: float) -> str:
    return f"{v:,.0f}" if float(v).is_integer() else f"{v:,.6g}"


def _amount(v: float, unit: str) -> str:
    if unit == "$":
        return f"${v:,.0f}"
    return f"{_fmt(round(float(v), 6))} {unit}".rstrip()
