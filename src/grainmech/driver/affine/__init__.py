"""The affine model: the seed's material point (every contact follows the mean strain, seed Eq. 2.13).

* :mod:`~grainmech.driver.affine.point` - :class:`MaterialPoint` (``isotropic``,
  ``at_stress``, ``from_forces``), :func:`evaluate`, the consistent and geometric tangents;
* :mod:`~grainmech.driver.affine.solver` - :func:`run` (step loop, Newton, subdivision),
  :class:`SolverOptions`;
* compiled paths: :mod:`~grainmech.driver.affine._fused` (every strain prescribed),
  :mod:`~grainmech.driver.affine._mixed` (mixed control, one compiled call per segment;
  its per-contact pieces in ``_mixed_rows``, its evaluation pass in ``_mixed_pass``) and
  :mod:`~grainmech.driver.affine._fold` (folding by the path's symmetries).

The same names are importable from :mod:`grainmech.driver`.
"""
