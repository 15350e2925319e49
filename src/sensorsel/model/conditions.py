"""Operating conditions: night, rain, fog and snow, and what they do to each sensor's range and noise.

A :class:`Condition` is data: ``night`` (bool), ``rain_mm_h`` and ``snow_mm_h`` (precipitation rate
[mm/h], >= 0) and ``fog_visibility_m`` (meteorological optical range, MOR [m], > 0; None: no fog).
All neutral (day, no rain, no snow, no fog) is the clear condition: results bit-identical to no
condition at all.

What a condition does to a sensor (:func:`sensor_effect`) comes from published models whose numbers
live in the sensor library file's ``conditions:`` section (:class:`ConditionPhysics`, cited there
beside each number; defaults here are the shipped file's):

- **Optical extinction** (LiDAR and cameras): α = α_fog + α_rain + α_snow [1/m]. Fog:
  α = ln(1/ε)/MOR with the 5 % contrast threshold ε of the MOR's definition (WMO/CIE), ≈ 3.0/MOR.
  Rain and snow: specific attenuations γ = k R^a [dB/km] (rain: Carbonneau's fit, as the FSO literature
  cites ITU-R P.1814; the Recommendation's text unchecked), turned into α = γ ln(10)/10⁴.
- **LiDAR range**: received power ∝ ρ e^(−2αR)/R², so the same target's farthest detection R solves
  R e^(αR) = R₀: R = W(α R₀)/α with Lambert's W (Hahner et al., ICCV 2021). Noise kept.
- **Camera range**: Koschmieder's contrast law C = C₀ e^(−αd) seen down to ε: d = ln(C₀/ε)/α; at
  night no farther than the headlights light (assumed); bearing and disparity noise times an
  assumed factor at night.
- **77 GHz radar range**: rain by ITU-R P.838-3 (γ = k R^a dB/km), fog by ITU-R P.840 (γ = K_l M,
  M the fog's liquid water [g/m³]); received power ∝ 10^(−2γr/10⁴)/r⁴ (two-way loss, radar
  equation) so R e^(αR/2) = R₀: R = 2 W(α R₀/2)/α. Night and snow: unchanged (assumed for snow).

A condition only shrinks ranges and inflates noise: each sensor's measurements under it are a
subset of its clear ones with larger noise (:func:`sensorsel.model.sensing.apply_condition`), so a suite
never gets more information in a more severe condition.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import asdict, dataclass, fields, replace
from typing import Any

from scipy.special import lambertw

from sensorsel.errors import InputError, LibraryError

#: the keys of a condition, in their canonical order
CONDITION_KEYS = ("night", "rain_mm_h", "fog_visibility_m", "snow_mm_h")
#: the name of the condition with every parameter neutral
CLEAR = "clear"
#: dB/km of specific attenuation -> power extinction coefficient [1/m]: 10^(-γ r/10^4) = e^(-α r)
DB_PER_KM_TO_PER_M = math.log(10.0) / 1.0e4


@dataclass(frozen=True)
class Condition:
    """An operating condition.

    Attributes:
        night: driving in the dark (cameras see as far as the headlights light).
        rain_mm_h: rain rate [mm/h] (0: none).
        fog_visibility_m: meteorological optical range in fog [m] (None: no fog).
        snow_mm_h: snowfall rate, liquid-water equivalent [mm/h] (0: none).
        name: its name in a domain file ("night", "rain"); "" for one given on the command line.

    Raises:
        InputError: a negative or non-finite rate, a visibility that is not > 0.
    """

    night: bool = False
    rain_mm_h: float = 0.0
    fog_visibility_m: float | None = None
    snow_mm_h: float = 0.0
    name: str = ""

    def __post_init__(self) -> None:
        if not isinstance(self.night, bool):
            raise InputError(f"condition night: expected true or false, got {self.night!r}")
        for key in ("rain_mm_h", "snow_mm_h"):
            v = getattr(self, key)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0:
                raise InputError(f"condition {key}: expected a finite number >= 0, got {v!r}")
        v = self.fog_visibility_m
        if v is not None and (isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0):
            raise InputError(f"condition fog_visibility_m: expected a visibility > 0 m, got {v!r}")

    @property
    def neutral(self) -> bool:
        """Day, no rain, no fog, no snow: what no condition is."""
        return not self.night and self.rain_mm_h == 0 and self.fog_visibility_m is None and self.snow_mm_h == 0

    @property
    def text(self) -> str:
        """The canonical ``--condition`` text: ``night,rain_mm_h=5`` (``clear`` when neutral)."""
        parts = ["night"] if self.night else []
        for key in ("rain_mm_h", "fog_visibility_m", "snow_mm_h"):
            v = getattr(self, key)
            if v is not None and v != 0:
                parts.append(f"{key}={v:g}")
        return ",".join(parts) or CLEAR

    @property
    def label(self) -> str:
        """Its name, else its text."""
        return self.name or self.text

    def parameters(self) -> dict[str, Any]:
        """The physical parameters (no name), as a plain mapping."""
        return {k: v for k, v in asdict(self).items() if k != "name"}


def parse_condition(text: str, option: str = "--condition") -> Condition:
    """A condition from its command-line text: comma-separated ``night``, ``clear`` or ``KEY=NUMBER``
    with KEY one of rain_mm_h, fog_visibility_m, snow_mm_h (``night,rain_mm_h=5``).

    Raises:
        InputError: naming ``option`` and the item: an unknown name or key, a key given twice, a value
            that is not a number, a negative rate, a visibility that is not > 0.
    """
    items = [t.strip() for t in str(text).split(",")]
    if not any(items):
        raise InputError(f"{option} {text!r}: empty; give e.g. night, rain_mm_h=5, fog_visibility_m=200")
    values: dict[str, Any] = {}
    for item in items:
        if not item:
            raise InputError(f"{option} {text!r}: an empty item between commas")
        key, eq, raw = item.partition("=")
        key = key.strip()
        if key not in CONDITION_KEYS and key != CLEAR:
            raise InputError(f"{option} {text!r}: unknown condition {key!r}; known: clear, {', '.join(CONDITION_KEYS)}")
        if key in values:
            raise InputError(f"{option} {text!r}: {key} given twice")
        if key in ("night", CLEAR):
            if eq:
                raise InputError(f"{option} {text!r}: {key} takes no value (write {key!r} alone)")
            values[key] = True
            continue
        if not eq:
            raise InputError(f"{option} {text!r}: {key} needs a value, e.g. {key}={_EXAMPLE[key]}")
        try:
            v = float(raw)
        except ValueError:
            raise InputError(f"{option} {text!r}: {key}: expected a number, got {raw.strip()!r}") from None
        values[key] = v
    clear = values.pop(CLEAR, False)
    if clear and values:
        raise InputError(f"{option} {text!r}: clear is every parameter neutral: give it alone")
    try:
        return Condition(**values)
    except InputError as exc:
        raise InputError(f"{option} {text!r}: {str(exc).removeprefix('condition ')}") from None


_EXAMPLE = {"rain_mm_h": "5", "fog_visibility_m": "200", "snow_mm_h": "2"}


# ------------------------------------------------------------------------------------- the physics


@dataclass(frozen=True)
class ConditionPhysics:
    """The numbers of the published models (the library file's ``conditions:`` section).

    Attributes:
        contrast_threshold: ε, the contrast an eye or a camera still tells from the background;
            0.05 in the MOR's definition (so α = ln(20)/MOR in fog).
        camera_contrast: C₀, a landmark's own contrast against its background for a camera
            (Koschmieder's law; 1 is a black object against the horizon sky, then d = MOR).
        optical_rain_k, optical_rain_a: optical rain attenuation γ = k R^a [dB/km] (R in mm/h;
            Carbonneau, cited as ITU-R P.1814) for LiDAR and cameras.
        optical_snow_k, optical_snow_a: (wet) snow attenuation γ = k S^a [dB/km] (cited as ITU-R P.1814; assumed).
        radar_rain_k, radar_rain_a: ITU-R P.838-3 at the radar's frequency, γ = k R^a [dB/km].
        radar_fog_db_km_per_g_m3: ITU-R P.840 K_l, fog attenuation per liquid water [(dB/km)/(g/m³)].
        fog_water_g_m3_at_50m, fog_water_exponent: the fog's liquid water M [g/m³] from its
            visibility V: M = M_50 (50 / V)^b.
        night_camera_range_m: the farthest a camera sees at night (the headlights) [m].
        night_camera_noise_factor: cameras' bearing and disparity noise multiplier at night.
    """

    contrast_threshold: float = 0.05
    camera_contrast: float = 1.0
    optical_rain_k: float = 1.076
    optical_rain_a: float = 0.67
    optical_snow_k: float = 3.878
    optical_snow_a: float = 0.72
    radar_rain_k: float = 1.13
    radar_rain_a: float = 0.72
    radar_fog_db_km_per_g_m3: float = 3.0
    fog_water_g_m3_at_50m: float = 0.5
    fog_water_exponent: float = 1.285
    night_camera_range_m: float = 40.0
    night_camera_noise_factor: float = 2.0

    def __post_init__(self) -> None:
        if not 0 < self.contrast_threshold < 1:
            raise InputError(
                f"conditions.contrast_threshold: expected a number in (0, 1), got {self.contrast_threshold!r}"
            )
        if not self.camera_contrast > self.contrast_threshold:
            raise InputError(
                f"conditions.camera_contrast: must exceed contrast_threshold, got {self.camera_contrast!r}"
            )
        if not self.night_camera_noise_factor >= 1:
            raise InputError(
                f"conditions.night_camera_noise_factor: expected >= 1, got {self.night_camera_noise_factor!r}"
            )


def parse_physics(raw: Any, path: Any, key: str = "conditions") -> ConditionPhysics:
    """The library file's ``conditions:`` section (any key omitted keeps its default).

    Raises:
        LibraryError: naming the file and ``conditions.KEY``: an unknown key, a value that is not a
            positive number (or not in range).
    """
    if not isinstance(raw, dict):
        raise LibraryError(
            path, key, f"expected a mapping of model numbers (contrast_threshold: 0.05, ...), got {raw!r}"
        )
    allowed = [f.name for f in fields(ConditionPhysics)]
    values: dict[str, float] = {}
    for k, v in raw.items():
        if k not in allowed:
            raise LibraryError(path, f"{key}.{k}", f"unknown key; allowed: {', '.join(allowed)}")
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
            raise LibraryError(path, f"{key}.{k}", f"expected a positive number, got {v!r}")
        values[k] = float(v)
    try:
        return replace(ConditionPhysics(), **values)
    except InputError as exc:
        raise LibraryError(path, "", str(exc)) from None


def fog_extinction_per_m(visibility_m: float, contrast_threshold: float = 0.05) -> float:
    """Extinction coefficient α [1/m] of fog of meteorological optical range ``visibility_m`` [m]:
    ln(1/ε)/MOR (Koschmieder, with the MOR's 5 % threshold: ≈ 2.996/MOR)."""
    return math.log(1.0 / contrast_threshold) / visibility_m


def power_law_db_per_km(rate: float, k: float, a: float) -> float:
    """Specific attenuation γ = k R^a [dB/km] of a precipitation rate R [mm/h] (0 for no precipitation)."""
    return k * rate**a if rate > 0 else 0.0


def range_under_extinction(range_m: float, alpha_per_m: float, exponent: int) -> float:
    """The farthest range [m] at which a sensor still detects what it detected at ``range_m`` in
    clear air, when its received power falls as e^(−2αr)/r^n (n = ``exponent``: 2 for a LiDAR on
    an extended target, 4 for a radar): r^n e^(2αr) = R₀^n, i.e. r e^(2αr/n) = R₀, so
    r = W(b R₀)/b with b = 2α/n and W Lambert's function (principal branch). ``alpha_per_m`` 0
    gives ``range_m`` itself."""
    if alpha_per_m <= 0:
        return range_m
    b = 2.0 * alpha_per_m / exponent
    return float(lambertw(b * range_m).real) / b


def koschmieder_range_m(alpha_per_m: float, contrast: float, threshold: float) -> float:
    """The distance [m] at which an object of inherent contrast C₀ = ``contrast`` fades to the
    threshold ε (C = C₀ e^(−αd)): d = ln(C₀/ε)/α; infinite in clear air (α = 0)."""
    return math.inf if alpha_per_m <= 0 else math.log(contrast / threshold) / alpha_per_m


def fog_water_g_m3(visibility_m: float, physics: ConditionPhysics) -> float:
    """Liquid water of fog [g/m³] from its visibility [m]: M_50 (50/V)^b (the power law through
    ITU-R P.840's two examples, 0.05 g/m³ at ~300 m and 0.5 g/m³ at ~50 m)."""
    return physics.fog_water_g_m3_at_50m * (50.0 / visibility_m) ** physics.fog_water_exponent


def optical_extinction_per_m(condition: Condition, physics: ConditionPhysics) -> float:
    """α [1/m] for LiDAR and cameras: fog (ln(1/ε)/MOR) plus rain and snow (cited as ITU-R P.1814)."""
    alpha = 0.0
    if condition.fog_visibility_m is not None:
        alpha += fog_extinction_per_m(condition.fog_visibility_m, physics.contrast_threshold)
    alpha += DB_PER_KM_TO_PER_M * power_law_db_per_km(
        condition.rain_mm_h, physics.optical_rain_k, physics.optical_rain_a
    )
    alpha += DB_PER_KM_TO_PER_M * power_law_db_per_km(
        condition.snow_mm_h, physics.optical_snow_k, physics.optical_snow_a
    )
    return alpha


def radar_extinction_per_m(condition: Condition, physics: ConditionPhysics) -> float:
    """α [1/m] for the 77 GHz radars: rain (ITU-R P.838-3) plus fog (ITU-R P.840); snow neglected."""
    gamma = power_law_db_per_km(condition.rain_mm_h, physics.radar_rain_k, physics.radar_rain_a)
    if condition.fog_visibility_m is not None:
        gamma += physics.radar_fog_db_km_per_g_m3 * fog_water_g_m3(condition.fog_visibility_m, physics)
    return DB_PER_KM_TO_PER_M * gamma


@dataclass(frozen=True)
class SensorEffect:
    """What a condition does to one sensor model.

    Attributes:
        range_m: its farthest measurement [m] under the condition (<= the model's own).
        bearing_factor: its bearing noise std multiplier (>= 1).
        range_factor: its range noise std multiplier (>= 1; stereo: the disparity noise's).
    """

    range_m: float
    bearing_factor: float = 1.0
    range_factor: float = 1.0

    def neutral_for(self, range_m: float) -> bool:
        return self.range_m == range_m and self.bearing_factor == 1.0 and self.range_factor == 1.0


def sensor_effect(
    sensor_type: str, range_m: float, condition: Condition | None, physics: ConditionPhysics
) -> SensorEffect:
    """The range and noise multipliers of a sensor of ``sensor_type`` ("lidar", "radar", "stereo")
    and clear-air range ``range_m`` [m] under ``condition`` (None or neutral: exactly the model's own)."""
    if condition is None or condition.neutral:
        return SensorEffect(range_m)
    if sensor_type == "lidar":
        return SensorEffect(
            min(range_m, range_under_extinction(range_m, optical_extinction_per_m(condition, physics), 2))
        )
    if sensor_type == "radar":
        return SensorEffect(
            min(range_m, range_under_extinction(range_m, radar_extinction_per_m(condition, physics), 4))
        )
    reach = min(
        range_m,
        koschmieder_range_m(
            optical_extinction_per_m(condition, physics), physics.camera_contrast, physics.contrast_threshold
        ),
    )
    factor = 1.0
    if condition.night:
        reach = min(reach, physics.night_camera_range_m)
        factor = physics.night_camera_noise_factor
    return SensorEffect(reach, factor, factor)


def condition_digest(condition: Condition | None, physics: ConditionPhysics) -> str | None:
    """sha256 (hex) of a condition's parameters and the physics it is applied with; None for no
    condition or a neutral one (so that it fingerprints like none)."""
    if condition is None or condition.neutral:
        return None
    text = json.dumps(
        {"condition": condition.parameters(), "physics": asdict(physics)}, sort_keys=True, allow_nan=False
    )
    return hashlib.sha256(text.encode("utf-8")).hexdigest()
