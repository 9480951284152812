"""``grainmech contact CONFIG.toml [-o OUTDIR] [--no-plot]``: drive one contact through a loading path.

The config names a contact law (``[contact]``, the same keys as ``[contacts]`` of the
other commands plus ``radius`` and an optional second body), an initial state
(``[initial]``) and a path of segments (``[[path]]``) in which the normal and the
tangential channel are each under force or displacement control. Output, written
atomically in OUTDIR (default ``./grainmech-out/contact``):

* ``contact.csv``: one row per step (step 0 is the initial state) with the columns
  ``step, segment, normal_displacement, tangential_displacement, normal_force,
  tangential_force, dissipated_energy, normal_stiffness, tangential_stiffness, sliding``
  (SI units; the tangential quantities are the components along the loading axis x;
  ``normal_displacement`` is the approach);
* ``contact.png``: tangential force-displacement loop and normal force-approach curve
  (skipped with ``--no-plot``).

Config reference (see ``examples/contact_*.toml`` and ``docs/config.md``)::

    [contact]
    law = "mindlin-deresiewicz"  # hertz | hertz-mindlin | mindlin-deresiewicz | linear | cylinder
    shear_modulus = "29 GPa"     # hertz family: shear_modulus, poisson, radius,
    poisson = 0.2                #   optional radius2, shear_modulus2, poisson2,
    radius = "1 mm"              #   friction or friction_angle (hertz-mindlin,
    friction = 0.5               #   mindlin-deresiewicz), max_reversals (mindlin-deresiewicz)
    # linear:   kn, ks, friction or friction_angle
    # cylinder: shear_modulus_equiv, poisson, radius, radius2, psi, friction_angle,
    #           max_reversals
    # angles carry their unit: friction_angle = "15 deg" (a bare number is an error)

    [initial]
    normal_force = "10 N"        # or approach = "1 um" (per unit length for cylinder)

    [[path]]                     # a ramp: targets reached linearly in `steps` steps
    steps = 20
    normal_force = "20 N"        # or normal_displacement (absolute approach); omit: hold
    tangential_force = "3 N"     # or tangential_displacement (absolute); omit: hold

    [[path]]                     # symmetric cycles of the tangential channel
    kind = "cycles"
    count = 2                    # number of full cycles +A -> -A -> +A
    steps = 40                   # steps per half cycle (the first ramp to +A takes steps/2)
    tangential_force_amplitude = "3 N"   # or tangential_displacement_amplitude

A held channel keeps its current control mode (force or displacement). Unknown keys are
errors.
"""

from __future__ import annotations

import argparse
from typing import Any

from grainmech.io.config import load_toml
from grainmech.io.outdir import output_folder
from grainmech.io.reports import default_outdir, write_contact_outputs

__all__ = ["register", "run"]


def register(sub: Any) -> None:
    """Add the ``grainmech contact`` sub-command and its options to ``sub`` (argparse sub-parsers)."""
    p = sub.add_parser(
        "contact", help="drive one contact through a path of normal/tangential loads",
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("config", help="TOML config (see examples/contact_*.toml)")
    p.add_argument("-o", "--outdir", default=default_outdir("contact"),
                   help="output folder (default ./%(default)s)")
    p.add_argument("--no-plot", action="store_true", help="do not write contact.png")
    p.add_argument("--quiet", action="store_true", help="no progress messages (results still go to stdout)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run ``grainmech contact`` with the parsed ``args``.

    Returns
    -------
    int
        Exit status: 0 on success; input errors raise :class:`~grainmech.errors.GrainmechError`,
        which :func:`grainmech.cli.main` turns into one line and status 2.
    """
    # imported on use: keeps `grainmech --help` start-up light
    from grainmech.jobs import compute_contact

    cfg = load_toml(args.config)
    with output_folder(args.outdir, "contact") as folder:  # checked and locked before the work
        out = compute_contact(cfg)
        staged = write_contact_outputs(out, folder.staging, plot=not args.no_plot)
    files = [folder.path / f.name for f in staged]
    print(f"wrote {files[0]} ({len(out.columns['step'])} rows)"
          + "".join(f" and {f}" for f in files[1:]))
    return 0
