"""Where the default sensor library, the bundled fixture scenarios and the sample OSM cities are.

A wheel carries them inside the package (``sensorsel/_data``); a source checkout or an editable
install finds them at the repository's top level (``configs/``, ``data/kitti_fixtures``).
"""

from __future__ import annotations

from pathlib import Path

_PACKAGE_DATA = Path(__file__).resolve().parents[1] / "_data"
_REPO_ROOT = Path(__file__).resolve().parents[3]


def default_library_path() -> Path:
    """Path of the default sensor library YAML (the paper's Table I, 62 placed sensors)."""
    packaged = _PACKAGE_DATA / "sensor_library.yaml"
    return packaged if packaged.is_file() else _REPO_ROOT / "configs" / "sensor_library.yaml"


def fixtures_dir() -> Path:
    """Folder of the bundled synthetic fixture scenarios (KITTI pose format + landmark CSVs)."""
    packaged = _PACKAGE_DATA / "kitti_fixtures"
    return packaged if packaged.is_dir() else _REPO_ROOT / "data" / "kitti_fixtures"


def sample_osm_dir() -> Path:
    """Folder of the bundled OpenStreetMap sample cities (``<name>.osm.pbf`` + README.md with the ODbL attribution)."""
    packaged = _PACKAGE_DATA / "osm"
    return packaged if packaged.is_dir() else _REPO_ROOT / "data" / "osm"


def sample_osm_names() -> list[str]:
    """Names of the bundled OSM sample cities (``sensorsel osm --sample NAME``)."""
    return sorted(p.name.removesuffix(".osm.pbf") for p in sample_osm_dir().glob("*.osm.pbf"))
