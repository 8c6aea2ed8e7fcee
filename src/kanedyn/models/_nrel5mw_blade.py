r"""The NREL 5-MW blade's aerodynamic table and airfoil polars, and its BEM rotor.

The data (``data/nrel5mw_blade.npz``, see ``data/NOTICE.md``) are the blade
stations of AeroDyn 15's ``NRELOffshrBsline5MW_AeroDyn_blade.dat`` (span from
the root, twist, chord, airfoil number) and the eight airfoil tables it numbers
(``Airfoils/*.dat``: two cylinders, DU40, DU35, DU30, DU25, DU21 and NACA 64
with aspect-ratio 17 corrections; angle of attack, :math:`C_l`, :math:`C_d`),
from OpenFAST's regression tests (github.com/OpenFAST/r-test,
``glue-codes/openfast/5MW_Baseline/``, Apache-2.0), read by
:func:`~kanedyn.offshore.read_blade_table` and
:func:`~kanedyn.offshore.read_airfoil_polar` and written by
:func:`write_nrel5mw_blade`.

``nrel5mw_blade``  the :class:`~kanedyn.offshore.BladeTable` and the polars
``nrel5mw_bem``    the rotor as a :class:`~kanedyn.offshore.BladeElementMomentum`
                   (3 blades, hub radius 1.5 m, tip radius 63 m, air of 1.225 kg/m^3,
                   Prandtl tip and hub losses, Buhl's high-induction correction)
"""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np

from .._errors import ModelError
from .._output_files import replacing
from ..modeling import (AirfoilPolar, BladeElementMomentum, BladeTable, read_airfoil_polar,
                        read_blade_table)
from ._oc3_data import ROTOR

__all__ = ["nrel5mw_blade", "nrel5mw_bem", "write_nrel5mw_blade", "NREL5MW_AIRFOILS",
           "NREL5MW_BLADE_DATA"]

#: the airfoil files in the order the blade file's BlAFID numbers them (its AeroDyn
#: input's AFNames)
NREL5MW_AIRFOILS = ("Cylinder1", "Cylinder2", "DU40_A17", "DU35_A17", "DU30_A17",
                    "DU25_A17", "DU21_A17", "NACA64_A17")
#: the shipped file
NREL5MW_BLADE_DATA = Path(__file__).parent / "data" / "nrel5mw_blade.npz"


def write_nrel5mw_blade(source, path=NREL5MW_BLADE_DATA):
    """Read the AeroDyn blade and airfoil files under ``source`` and write the .npz.

    Parameters
    ----------
    source : str or Path
        A directory holding ``NRELOffshrBsline5MW_AeroDyn_blade.dat`` and
        ``Airfoils/<name>.dat`` for each of :data:`NREL5MW_AIRFOILS`.
    path : str or Path
        The file written.
    """
    source = Path(source)
    blade = read_blade_table(source / "NRELOffshrBsline5MW_AeroDyn_blade.dat")
    arrays = dict(span=blade.span, twist=blade.twist, chord=blade.chord,
                  airfoil=blade.airfoil, names=np.array(NREL5MW_AIRFOILS))
    for i, name in enumerate(NREL5MW_AIRFOILS):
        polar = read_airfoil_polar(source / "Airfoils" / f"{name}.dat")
        arrays[f"polar{i}"] = np.column_stack([polar.angle_of_attack, polar.lift,
                                               polar.drag])
    with replacing(Path(path), "wb") as handle:
        np.savez_compressed(handle, **arrays)


@functools.lru_cache(maxsize=1)
def nrel5mw_blade():
    """The blade's stations and its airfoils' polars from the shipped file.

    Returns
    -------
    (BladeTable, tuple of AirfoilPolar)
    """
    try:
        with np.load(NREL5MW_BLADE_DATA, allow_pickle=False) as data:
            names = [str(n) for n in data["names"]]
            blade = BladeTable(data["span"], data["twist"], data["chord"], data["airfoil"])
            polars = tuple(AirfoilPolar(name, *data[f"polar{i}"].T)
                           for i, name in enumerate(names))
    except (OSError, KeyError, ValueError) as exc:
        raise ModelError(f"{NREL5MW_BLADE_DATA}: the NREL 5-MW blade data cannot be read "
                         f"({exc}); reinstall kanedyn") from None
    return blade, polars


@functools.lru_cache(maxsize=1)
def nrel5mw_bem():
    """The NREL 5-MW rotor as a :class:`~kanedyn.offshore.BladeElementMomentum`."""
    blade, polars = nrel5mw_blade()
    return BladeElementMomentum(blade, polars, ROTOR["hub_radius"].value,
                                ROTOR["diameter"].value / 2, int(ROTOR["n_blades"].value),
                                ROTOR["air_density"].value)
