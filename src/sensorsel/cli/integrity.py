"""The integrity options, shared by score and the selecting commands (one group; docs/guide-integrity.md)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import click

from sensorsel.cli.vocabulary import TopicOption

#: the integrity options' destinations, popped from a command's keywords by :func:`integrity_from`
INTEGRITY_KEYS = (
    "integrity_risk",
    "alert_lateral",
    "alert_longitudinal",
    "alert_heading",
    "gate_probability",
    "max_association_risk",
)


def _integrity_option(name: str, default: float | None, metavar: str, help: str) -> Any:
    """One integrity option: a float, listed under ``sensorsel help integrity``, destination its name's."""
    return click.option(
        name,
        name[2:].replace("-", "_"),
        cls=TopicOption,
        topic="integrity",
        type=float,
        default=default,
        show_default=default is not None,
        metavar=metavar,
        help="Integrity: " + help,
    )


def integrity_options(fn: Callable[..., Any]) -> Callable[..., Any]:
    """The integrity options, one group: the risk per hour, the alert limits, the associator's gate
    and the lever (defaults: Reid et al.'s local streets, 10⁻⁸ per hour; docs/guide-integrity.md).
    Read them with :func:`integrity_from`."""
    opts = [
        _integrity_option(
            "--integrity-risk", 1e-8, "P", "the allowed probability per hour of an error beyond an alert limit."
        ),
        _integrity_option("--alert-lateral", 0.29, "METRES", "the lateral alert limit [m]."),
        _integrity_option("--alert-longitudinal", 0.29, "METRES", "the longitudinal alert limit [m]."),
        _integrity_option("--alert-heading", 0.50, "DEGREES", "the heading alert limit [deg]."),
        _integrity_option(
            "--gate-probability", 0.9999, "P", "the associator's chi-square gate probability (2 degrees of freedom)."
        ),
        _integrity_option(
            "--max-association-risk",
            None,
            "P",
            "leave out (do not use) every measurement whose probability of a wrong association "
            "exceeds P; accuracy and integrity are then computed with what is used.",
        ),
    ]
    for opt in reversed(opts):
        fn = opt(fn)
    return fn


def integrity_from(kw: dict[str, Any]) -> Any:
    """The :class:`~sensorsel.information.integrity.IntegritySpec` of the integrity options (popped
    from ``kw``); an InputError naming the option when a value is out of range."""
    from sensorsel.api import IntegritySpec

    v = {k: kw.pop(k) for k in INTEGRITY_KEYS}
    return IntegritySpec(
        integrity_risk=v["integrity_risk"],
        alert_lateral_m=v["alert_lateral"],
        alert_longitudinal_m=v["alert_longitudinal"],
        alert_heading_deg=v["alert_heading"],
        gate_probability=v["gate_probability"],
        max_association_risk=v["max_association_risk"],
    )
