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


def integrity_options(fn: Callable[..., Any]) -> Callable[..., Any]:
    """The integrity options, one group: the risk per hour, the alert limits, the associator's gate
    and the lever (defaults: Reid et al.'s local streets, 10⁻⁸ per hour; docs/guide-integrity.md).
    Read them with :func:`integrity_from`."""
    opts = [
        click.option(
            "--integrity-risk",
            "integrity_risk",
            cls=TopicOption,
            topic="integrity",
            type=float,
            default=1e-8,
            show_default=True,
            metavar="P",
            help="Integrity: the allowed probability per hour of an error beyond an alert limit.",
        ),
        click.option(
            "--alert-lateral",
            "alert_lateral",
            cls=TopicOption,
            topic="integrity",
            type=float,
            default=0.29,
            show_default=True,
            metavar="METRES",
            help="Integrity: the lateral alert limit [m].",
        ),
        click.option(
            "--alert-longitudinal",
            "alert_longitudinal",
            cls=TopicOption,
            topic="integrity",
            type=float,
            default=0.29,
            show_default=True,
            metavar="METRES",
            help="Integrity: the longitudinal alert limit [m].",
        ),
        click.option(
            "--alert-heading",
            "alert_heading",
            cls=TopicOption,
            topic="integrity",
            type=float,
            default=0.50,
            show_default=True,
            metavar="DEGREES",
            help="Integrity: the heading alert limit [deg].",
        ),
        click.option(
            "--gate-probability",
            "gate_probability",
            cls=TopicOption,
            topic="integrity",
            type=float,
            default=0.9999,
            show_default=True,
            metavar="P",
            help="Integrity: the associator's chi-square gate probability (2 degrees of freedom).",
        ),
        click.option(
            "--max-association-risk",
            "max_association_risk",
            cls=TopicOption,
            topic="integrity",
            type=float,
            default=None,
            metavar="P",
            help="Integrity: leave out (do not use) every measurement whose probability of a wrong association "
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
