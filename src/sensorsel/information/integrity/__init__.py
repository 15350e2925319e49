"""Integrity: the risk of associating a measurement with the wrong landmark, the risk of an error
beyond the alert limits, protection levels, and the bounds a search for the cheapest suite needs.

- :mod:`~sensorsel.information.integrity.association`: the associator (gated nearest neighbour on the
  NIS) and each measurement's P(wrong association): a calibrated estimate and a bound;
- :mod:`~sensorsel.information.integrity.risk`: per keyframe integrity risk and protection levels, per
  hour, the lever that leaves risky measurements out (:class:`RouteIntegrity`, a result kind);
- :mod:`~sensorsel.information.integrity.bounds`: the check of a suite and its monotone bounds.
"""

from sensorsel.information.integrity.association import AssociationModel, MeasurementRisk, gate_of, measurement_risks
from sensorsel.information.integrity.bounds import IntegrityBounds
from sensorsel.information.integrity.risk import IntegritySpec, LeftOut, RouteIntegrity, route_integrity

__all__ = [
    "AssociationModel",
    "IntegrityBounds",
    "IntegritySpec",
    "LeftOut",
    "MeasurementRisk",
    "RouteIntegrity",
    "gate_of",
    "measurement_risks",
    "route_integrity",
]
