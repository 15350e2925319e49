"""Results and files: result kinds, their JSON codec, atomic writes, input files, progress and bundled data.

- :mod:`~sensorsel.io.results`: result kinds, registered by their classes, saved and loaded with provenance;
- :mod:`~sensorsel.io.legacy`: what files an older sensorsel wrote need to be read (until the release it names);
- :mod:`~sensorsel.io.codec`: the JSON encoding of results (exact floats, stable keys);
- :mod:`~sensorsel.io.files`: atomic writes and quiet standard output;
- :mod:`~sensorsel.io.inputs`: reading and checking input YAML files (every parser's one checker);
- :mod:`~sensorsel.io.progress`: progress reports of long runs;
- :mod:`~sensorsel.io.resources`: where the bundled library, fixtures and sample cities are.
"""
