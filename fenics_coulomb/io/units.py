"""The units the outputs are labelled with: the stress unit of the bilinear form's law (E's unit) and the mesh's
length unit, from which every other unit follows (a pressure and a traction are stresses, an area is a length
squared, a force a stress times an area).

The solver is unit-agnostic: it returns what the form's numbers mean. The scenes and the command give E in GPa on a
mesh in some length unit L, the default here; an API user whose form is in Pa on a mesh in metres says so
(``write_results(..., units={"stress": "Pa", "length": "m"})``) and every output — summary.json's ``units``, the
XDMF grid's ``units`` item, path.csv's column headers, the figures' axes — says Pa, m, m^2 and Pa*m^2.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from fenics_coulomb.errors import InputError

__all__ = ["Units"]

#: The longest unit name accepted.
MAX_UNIT_LENGTH = 32


@dataclass(frozen=True)
class Units:
    """The outputs' units.

    Attributes:
        stress: The unit of stress (of E in the form): pressures, tractions, stresses.
        length: The mesh's length unit: displacements, gaps, positions.
    """

    stress: str = "GPa"
    length: str = "L"

    @property
    def area(self) -> str:
        return f"{self.length}^2"

    @property
    def force(self) -> str:
        return f"{self.stress}*{self.length}^2"

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
        ``length``; InputError naming ``where`` otherwise (pure: the same on every rank)."""
        if value is None:
            return cls()
        if isinstance(value, Units):
            return cls.of({"stress": value.stress, "length": value.length}, where)
        if not isinstance(value, Mapping):
            raise InputError(f"{where} = {value!r}: give a dict such as {{'stress': 'MPa', 'length': 'mm'}}")
        unknown = sorted(str(k) for k in value if k not in ("stress", "length"))
        if unknown:
            raise InputError(f"{where}: unknown key {unknown[0]!r} (the keys: 'stress', 'length')")
        for key, unit in value.items():
            if (not isinstance(unit, str) or not unit.strip() or len(unit) > MAX_UNIT_LENGTH or not unit.isprintable()
                    or any(c in unit for c in ",[]\"")):
                raise InputError(f"{where}: {key} = {unit!r}: give a unit's name, 1 to {MAX_UNIT_LENGTH} printable "
                                 "characters without ',', '[', ']' or '\"'")
        return cls(**{k: v.strip() for k, v in value.items()})
