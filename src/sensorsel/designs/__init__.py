"""Designs: the selectors and searches that choose a suite, each written once as a plan of tasks.

- :mod:`~sensorsel.designs.selection`: greedy rules under a budget and limits (the paper's Algorithm 1);
- :mod:`~sensorsel.designs.certify`: certificates of near-optimality and exact optima;
- :mod:`~sensorsel.designs.tradespace`: the cost-performance tradespace and its Pareto front;
- :mod:`~sensorsel.designs.resilient`: resilient selection against failing sensors, per period (Algorithm 2);
- :mod:`~sensorsel.designs.robust`: the best worst case under failures, with its bound;
- :mod:`~sensorsel.designs.domain_design`: one suite for every route (and condition) of a domain;
- :mod:`~sensorsel.designs.requirements`: the cheapest suite meeting an accuracy specification in metres;
- :mod:`~sensorsel.designs.study`: a grid of design runs;
- :mod:`~sensorsel.designs.checkpoint`: the greedy run as a plan of resumable steps.
"""
