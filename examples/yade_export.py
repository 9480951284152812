"""Export a YADE contact network to grainmech's generic CSV tables.

Run inside YADE (not part of the grainmech test suite), e.g. at the end of a script or in
the YADE console after loading a saved simulation::

    yade -n -x yade_export.py  saved_state.yade.gz  out_prefix

or ``exec(open("yade_export.py").read()); export("out_prefix")`` from the console.

It writes ``<prefix>_contacts.csv`` and ``<prefix>_particles.csv`` in the format read by
``grainmech.io.dem.read_table`` / ``grainmech dem <prefix>_contacts.csv --particles
<prefix>_particles.csv`` (see docs/networks.md):

* contacts: ``id1,id2,fx,fy,fz,cpx,cpy,cpz,delta,kn,ks`` - one row per *real* interaction
  between two spheres; ``f = i.phys.normalForce + i.phys.shearForce``. In YADE's
  ``ScGeom`` the normal points from ``id1`` to ``id2`` and the law applies ``+F`` to
  ``id2`` and ``-F`` to ``id1`` (``Law2_ScGeom_FrictPhys_CundallStrack``), so ``f`` is
  the force exerted by id1 on id2 - grainmech's convention, no sign change. A compressive
  contact then has ``f . (x2 - x1) > 0``. ``delta = i.geom.penetrationDepth`` (overlap),
  ``kn, ks`` are the interaction's current stiffnesses (FrictPhys).
* particles: ``id,x,y,z,radius`` of all spheres.
* the periodic cell (``O.periodic``): ``# cell:`` rows of ``O.cell.hSize`` (columns are
  the cell vectors in YADE, so it is transposed here), ``# origin: 0 0 0`` and
  ``# periodic: 1 1 1``; otherwise the axis-aligned bounding box of the spheres,
  non-periodic (the volume of the box is then the averaging volume: prefer a periodic
  cell or give a box yourself).

Particle positions of a periodic simulation are wrapped into the cell
(``O.cell.wrap``); grainmech recomputes each branch vector as the minimum image.
"""

import sys


def export(prefix):  # pragma: no cover - runs inside YADE only
    from yade.wrapper import Omega, Sphere  # available inside YADE only

    O = Omega()  # the simulation singleton (the `O` of YADE scripts)

    spheres = [b for b in O.bodies if b is not None and isinstance(b.shape, Sphere)]
    ids = set(b.id for b in spheres)
    lines = ["# grainmech generic contact table exported from YADE; force exerted by id1 on id2"]
    if O.periodic:
        H = O.cell.hSize  # columns are the cell vectors
        rows = [[H[r][c] for r in range(3)] for c in range(3)]
        lines.append("# cell: " + " ".join("%.17g" % v for row in rows for v in row))
        lines.append("# origin: 0 0 0")
        lines.append("# periodic: 1 1 1")
    else:
        lo = [min(b.state.pos[k] - b.shape.radius for b in spheres) for k in range(3)]
        hi = [max(b.state.pos[k] + b.shape.radius for b in spheres) for k in range(3)]
        lines.append("# box: " + " ".join("%.17g %.17g" % (lo[k], hi[k]) for k in range(3)))
        lines.append("# periodic: 0 0 0")
    head = "\n".join(lines) + "\n"
    with open(prefix + "_contacts.csv", "w") as fh:
        fh.write(head)
        fh.write("id1,id2,fx,fy,fz,cpx,cpy,cpz,delta,kn,ks\n")
        for i in O.interactions:
            if not i.isReal or i.id1 not in ids or i.id2 not in ids:
                continue
            f = i.phys.normalForce + i.phys.shearForce
            cp = i.geom.contactPoint
            fh.write("%d,%d,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g\n" % (
                i.id1, i.id2, f[0], f[1], f[2], cp[0], cp[1], cp[2], i.geom.penetrationDepth,
                i.phys.kn, i.phys.ks))
    with open(prefix + "_particles.csv", "w") as fh:
        fh.write(head)
        fh.write("id,x,y,z,radius\n")
        for b in spheres:
            p = O.cell.wrap(b.state.pos) if O.periodic else b.state.pos
            fh.write("%d,%.17g,%.17g,%.17g,%.17g\n" % (b.id, p[0], p[1], p[2], b.shape.radius))


if __name__ == "__main__":  # pragma: no cover
    export(sys.argv[-1] if len(sys.argv) > 1 else "yade_network")
