"""The model of a design problem: what is bought, where it is driven and what it sees.

- :mod:`~sensorsel.model.library`: the sensor library (models, placements, costs and resources);
- :mod:`~sensorsel.model.conditions`: operating conditions (night, rain, fog, snow) and what they do to each model;
- :mod:`~sensorsel.model.scenario`: routes and landmark maps read from any frame (KITTI, TUM, CSV, GPX);
- :mod:`~sensorsel.model.osm`: routes and landmarks of a city from OpenStreetMap;
- :mod:`~sensorsel.model.domain`: the operating-domain file (routes, weights, conditions);
- :mod:`~sensorsel.model.sensing`: which landmark each placed sensor measures at each keyframe;
- :mod:`~sensorsel.model.problem`: a route or domain problem, built once and shared by every design;
- :mod:`~sensorsel.model.constraints`: budget and resource limits on a suite.

Nothing here builds a factor graph: that is :mod:`sensorsel.information`.
"""
