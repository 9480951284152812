"""Where the DEM model's time goes: cProfile of one step-and-relax amplitude on a shipped packing.

Usage: ``python benchmarks/dem_profile.py`` (needs ``grainmech[dem]``). Runs 'nevada-medium'
(2000 Nevada-sand grains with rolling resistance mu_r 0.25) at 3e-4, one cycle of 8 steps,
100 kPa, and prints the wall time, the LAMMPS time steps and the 15 functions with the
largest own time: LAMMPS' ``command`` (its ``run`` commands) against the Python checks,
gathers (``extract_compute``) and the servo's solves (``block_cg``).
"""
import cProfile, pstats, time
from grainmech.packing import load_packing, packing_info
from grainmech.contact import HertzMindlin, RollingResistance
from grainmech.driver import cyclic_simple_shear
from grainmech.driver.dem import DemSettings, run_dem
net = load_packing("nevada-medium"); m = packing_info("nevada-medium")["material"]
law = HertzMindlin(m["shear_modulus_Pa"], m["poisson"], float(net.radii.mean()), friction=m["friction"])
path = cyclic_simple_shear(3e-4, 1, 8)
t0 = time.perf_counter()
pr = cProfile.Profile(); pr.enable()
r = run_dem(net, law, path, DemSettings(), pressure=1e5, rolling=RollingResistance(0.25))
pr.disable()
print("wall", time.perf_counter() - t0, "steps", int(sum(r.iterations)), r.message)
st = pstats.Stats(pr); st.sort_stats("tottime").print_stats(15)
