"""The information a suite gives: the linearized SLAM graph and the evaluators that score it.

- :mod:`~sensorsel.information.linearize`: the base graph's information in closed form (GTSAM's Jacobians);
- :mod:`~sensorsel.information.graph`: the GTSAM factor graph of a suite (the reference);
- :mod:`~sensorsel.information.evaluators`: log det [nats] and accuracy [m, deg] of a suite, by a registered engine.
"""
