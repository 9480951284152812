"""Generate the small example DEM files ``examples/dem_*`` (run from the repository root).

    python examples/dem_make_examples.py

Writes a periodic triclinic random network of 250 polydisperse Hertz spheres as a
LIGGGHTS ``dump local`` (pos,id,force,contactPoint,delta; force on the first particle,
tension-positive as LIGGGHTS writes it) + particle ``dump custom``, the same network as
the generic CSV tables, and a material config for ``grainmech dem``::

    grainmech dem examples/dem_liggghts_contacts.dump \
        --particles examples/dem_liggghts_particles.dump \
        --material examples/dem_material.toml -o dem_out
"""

from pathlib import Path

import numpy as np

from grainmech.io.dem import write_liggghts, write_table
from grainmech.network import random_network

here = Path(__file__).parent
cell = np.array([[13.7, 0, 0], [1.7, 12.8, 0], [0.85, -1.3, 14.5]])
net = random_network(250, coordination=7.0, cell=cell, radius_range=(0.9, 1.1), seed=2024,
                     shear_modulus=29e9, poisson=0.15, tangential=0.2)
write_liggghts(net, here / "dem_liggghts_contacts.dump", here / "dem_liggghts_particles.dump")
write_table(net, here / "dem_table_contacts.csv", here / "dem_table_particles.csv")
(here / "dem_material.toml").write_text(
    "# grain properties for `grainmech dem` (quartz-like), see docs/networks.md\n"
    "[material]\nshear_modulus = \"29 GPa\"\npoisson = 0.15\n\n"
    "[stiffness]\nsource = \"overlap\"   # auto | overlap | force | columns | constant\n"
    "geometric = false\n\n"
    "[relaxed]\nenabled = true\nsolver = \"auto\"\nremove_rattlers = true\n\n"
    "[fabric]\nfit_order = 2\n")
print("wrote", ", ".join(sorted(p.name for p in here.glob("dem_*"))))
