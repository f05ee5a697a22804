"""The units the outputs are labelled with: the stress unit of the bilinear form's law (E's unit) and the mesh's
length unit, from which every other unit follows (a pressure and a traction are stresses, an area is a length
squared, a force a stress times an area).

The solver is unit-agnostic: it returns what the form's numbers mean. The scenes and the command give E in GPa on a
mesh in some length unit L, the default here; an API user whose form is in Pa on a mesh in metres says so
(``write_results(..., units={"stress": "Pa", "length": "m"})``) and the result set — summary.json's ``units``, the
``units`` items of solution.xdmf and obstacles.xdmf, the contact-pressure figure — says Pa, m, m^2 and Pa*m^2. (A
load path's result set is the command's: path.csv and path.png in the default units.) A derived unit puts a compound
name in parentheses: length "0.1 m" gives the area "(0.1 m)^2".
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from fenics_coulomb.errors import InputError

__all__ = ["Units"]

#: The longest unit name accepted.
MAX_UNIT_LENGTH = 32


#: Characters a unit's name may not hold: the separators of the XDMF units item and of path.csv's headers, JSON's
#: quote, and matplotlib's mathtext delimiter (a label "$x^$" fails to draw).
FORBIDDEN = ',[]"$'


def _grouped(unit: str) -> str:
    """``unit`` in parentheses when it is compound (a space or an operator), so that a power or product of it reads
    as one."""
    return f"({unit})" if any(c in unit for c in " */^") else unit


@dataclass(frozen=True)
class Units:
    """The outputs' units (checked when made: InputError for a name that is not a unit's).

    Attributes:
        stress: The unit of stress (of E in the form): pressures, tractions, stresses.
        length: The mesh's length unit: displacements, gaps, positions.
    """

    stress: str = "GPa"
    length: str = "L"

    def __post_init__(self) -> None:
        for key in ("stress", "length"):
            unit = getattr(self, key)
            if (not isinstance(unit, str) or not unit.strip() or unit != unit.strip() or len(unit) > MAX_UNIT_LENGTH
                    or not unit.isprintable() or any(c in unit for c in FORBIDDEN)):
                raise InputError(f"units: {key} = {unit!r}: give a unit's name, 1 to {MAX_UNIT_LENGTH} printable "
                                 f"characters without {', '.join(repr(c) for c in FORBIDDEN)} or surrounding spaces")

    @property
    def area(self) -> str:
        return f"{_grouped(self.length)}^2"

    @property
    def force(self) -> str:
        return f"{_grouped(self.stress)}*{self.area}"

    def table(self) -> dict[str, str]:
        """summary.json's ``units``: length, area, pressure, stress, force."""
        return {"length": self.length, "area": self.area, "pressure": self.stress, "stress": self.stress,
                "force": self.force}

    def fields(self) -> dict[str, str]:
        """The unit of every point field of solution.xdmf ("" for a dimensionless or categorical field)."""
        return {"displacement": self.length, "contact_state": "", "contact_pressure": self.stress,
                "contact_force": self.force, "tangential_force": self.force, "contact_traction": self.stress,
                "gap": self.length, "contact_normal": "", "master_reaction": self.force, "stress": self.stress,
                "von_mises": self.stress, "body": ""}

    @classmethod
    def of(cls, value: Any, where: str) -> Units:
        """``value`` as Units: None (the default, GPa and L), Units, or a mapping with the keys ``stress`` and/or
        ``length`` (names stripped of surrounding spaces); InputError naming ``where`` otherwise (pure: the same on
        every rank)."""
        if value is None or isinstance(value, Units):
            return value or cls()
        if not isinstance(value, Mapping):
            raise InputError(f"{where} = {value!r}: give a dict such as {{'stress': 'MPa', 'length': 'mm'}}")
        unknown = sorted(str(k) for k in value if k not in ("stress", "length"))
        if unknown:
            raise InputError(f"{where}: unknown key {unknown[0]!r} (the keys: 'stress', 'length')")
        try:
            return cls(**{k: v.strip() if isinstance(v, str) else v for k, v in value.items()})
        except InputError as err:
            raise InputError(f"{where}: {str(err).removeprefix('units: ')}") from None
