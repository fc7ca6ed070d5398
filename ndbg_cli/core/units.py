"""Length units.

ndbg keeps every length of an assembly in the assembly's own unit (its manifest's ``units``,
millimetres by default); a part declared in another unit is scaled into it when loaded.
"""

from __future__ import annotations

from .errors import InputError

#: Millimetres per unit, for every unit name ndbg accepts (canonical names first).
MM_PER_UNIT: dict[str, float] = {"mm": 1.0, "cm": 10.0, "m": 1000.0, "in": 25.4}

_ALIASES = {
    "millimeter": "mm", "millimeters": "mm", "millimetre": "mm", "millimetres": "mm",
    "centimeter": "cm", "centimeters": "cm", "centimetre": "cm", "centimetres": "cm",
    "meter": "m", "meters": "m", "metre": "m", "metres": "m",
    "inch": "in", "inches": "in",
}


def canonical_unit(name: str, *, file: str | None = None, part: str | None = None) -> str:
    """Return the canonical unit name (``mm``, ``cm``, ``m``, ``in``) for ``name``.

    Raises :class:`InputError` for an unknown unit.
    """
    key = str(name).strip().lower()
    key = _ALIASES.get(key, key)
    if key not in MM_PER_UNIT:
        known = ", ".join(MM_PER_UNIT)
        raise InputError(f"unknown unit '{name}' (known: {known})", file=file, part=part)
    return key


def scale(from_unit: str, to_unit: str) -> float:
    """Factor that converts a length in ``from_unit`` to ``to_unit``."""
    return MM_PER_UNIT[canonical_unit(from_unit)] / MM_PER_UNIT[canonical_unit(to_unit)]
