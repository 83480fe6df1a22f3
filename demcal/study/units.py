"""Units a target may be given in, and the factor to each response's own unit.

A lab sheet gives a bulk density in g/cm³ or a mass flow in t/h; demcal's responses are in SI
(and the angle of repose in degrees, as it is measured). A target in one of these units is
converted when the study is loaded, and the conversion is said once.
"""

from __future__ import annotations

import math

#: For each unit a response is measured in: the other spellings and units a target may use,
#: with the factor that converts a value in them to that unit.
CONVERSIONS: dict[str, dict[str, float]] = {
    "deg": {"°": 1.0, "degree": 1.0, "degrees": 1.0, "rad": 180.0 / math.pi},
    "kg/m^3": {
        "kg/m3": 1.0,
        "kg/m³": 1.0,
        "g/l": 1.0,
        "g/L": 1.0,
        "kg/l": 1000.0,
        "kg/L": 1000.0,
        "g/cm^3": 1000.0,
        "g/cm3": 1000.0,
        "g/cm³": 1000.0,
        "g/ml": 1000.0,
        "g/mL": 1000.0,
        "t/m^3": 1000.0,
        "t/m3": 1000.0,
        "t/m³": 1000.0,
    },
    "kg/s": {"g/s": 1e-3, "kg/min": 1.0 / 60.0, "kg/h": 1.0 / 3600.0, "t/h": 1000.0 / 3600.0},
    "s": {"ms": 1e-3, "min": 60.0},
}


def conversion_factor(given: str, unit: str) -> float | None:
    """The factor that turns a value in ``given`` into ``unit`` (1 for the same unit); None
    when demcal does not convert between them."""
    if given == unit:
        return 1.0
    return CONVERSIONS.get(unit, {}).get(given)
