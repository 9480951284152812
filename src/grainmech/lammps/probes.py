"""Strain probes with LAMMPS: the measured small-strain tangent tensor of a packing.

From the relaxed reference state (:func:`grainmech.lammps.session.load_network`,
:func:`~grainmech.lammps.session.relax`) each strain component is applied as a small
increment (ramp, relax until the unbalanced force ratio is below ``tol`` and the stress
has settled) and taken back; the stress change over the strain is one column of the
tensor. The stress is the Love-Weber average of the contact forces at equilibrium (seed
Eq. 2.6), so the damping changes the path between equilibria, not the equilibria.
``scripts/dem_reference.py`` stores the result for the tests that run without LAMMPS.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from grainmech.contact.rolling import RollingConstants
from grainmech.lammps.engine import Lammps
from grainmech.lammps.granular import GrainMaterial
from grainmech.lammps.session import load_network, ramp, relax, voigt
from grainmech.network import ContactNetwork, network_stress

__all__ = ["ProbeResult", "strain_probes"]

Progress = Callable[[str], None]


@dataclass
class ProbeResult:
    """Strain probes: the measured tangent tensor (Voigt, compression positive) [Pa]."""

    C: np.ndarray
    strain: float
    network: ContactNetwork
    stress0: np.ndarray
    unbalanced: np.ndarray
    settings: dict
    seconds: float


def strain_probes(net: ContactNetwork, mat: GrainMaterial, *, strain: float = 1e-6, tol: float = 1e-5,
                  ramp_steps: int = 2000, max_relax_steps: int = 200_000, viscous: float = 0.01,
                  settle: float = 1e-3, threads: int | None = None,
                  progress: Progress | None = None, components: Sequence[int] = range(6),
                  rolling: RollingConstants | None = None) -> ProbeResult:
    """Small-strain probes of the six strain components on a packing (module notes).

    ``components``: the strain components probed (Voigt indices; the other columns of
    ``C`` stay NaN); ``rolling``: rolling and twisting resistance (:func:`load_network`).

    Each component ``k``: from the relaxed reference state apply ``+strain`` (ramp, relax
    until the unbalanced force ratio is below ``tol`` and the stress changes over a chunk
    of 500 steps by less than ``settle`` times the probe's stress change),
    read the stress, return to the reference strain (ramp, relax). Column ``k`` of ``C`` is
    the stress change over the strain; the reference stress for each probe is the one
    measured just before it.

    Returns
    -------
    ProbeResult
        ``C`` (6, 6) [Pa] (rows: stress components; columns: strain components), the
        re-equilibrated reference network, the stress before the probes (6,) [Pa], the
        unbalanced force ratio at every equilibrium, the settings and the wall time.
    """
    say = progress or (lambda m: None)
    t0 = time.perf_counter()
    C = np.full((6, 6), np.nan)
    ubs = []
    with Lammps(threads) as lmp:
        s = load_network(lmp, net, mat, viscous=viscous, rolling=rolling)
        ref, ub, n = relax(s, tol, max_relax_steps)
        ubs.append(ub)
        say(f"  reference state relaxed in {n} steps (unbalanced {ub:.2e})")
        sig0 = voigt(np.asarray(network_stress(ref).stress))
        base = sig0
        for k in components:
            de = np.zeros(6)
            de[k] = strain
            ramp(s, de, ramp_steps)
            nk, ub, n = relax(s, tol, max_relax_steps, settle=(base, settle))
            ubs.append(ub)
            sk = voigt(np.asarray(network_stress(nk).stress))
            C[:, k] = (sk - base) / strain
            ramp(s, -de, ramp_steps)
            nb, ub, n2 = relax(s, tol, max_relax_steps, settle=(sk, settle))
            ubs.append(ub)
            base = voigt(np.asarray(network_stress(nb).stress))
            say(f"  probe {k + 1}/6: C[{k},{k}] = {C[k, k]:.4g} Pa ({n} + {n2} relaxation steps, "
                f"{time.perf_counter() - t0:.0f} s)")
    settings = {"strain": strain, "tol": tol, "settle": settle, "ramp_steps": ramp_steps, "viscous": viscous,
                "time_step_s": s.dt, "restitution": mat.restitution,
                "rolling": None if rolling is None else rolling.source}
    return ProbeResult(C, strain, ref, sig0, np.array(ubs), settings, time.perf_counter() - t0)
