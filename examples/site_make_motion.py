"""Generate ``examples/site_motion_synthetic.csv``, the input motion of ``site_sand_column.toml``.

    python examples/site_make_motion.py

A synthetic, not a recorded, motion: band-limited white noise (0.5-15 Hz, seeded) under
a Saragoni-Hart-type envelope ``(t/t1)^2 exp(2 (1 - t/t1))`` rising to its peak at
t1 = 4 s, scaled to a peak ground acceleration of 0.15 g; 20 s at dt = 0.01 s. Two
columns, time [s] and acceleration [m/s^2] (``[motion] units = "m/s^2"``). For a real
analysis use a recorded motion (an AT2 file from the PEER database, ``format = "peer"``).
"""

from pathlib import Path

import numpy as np

G = 9.80665
dt, duration, pga = 0.01, 20.0, 0.15
t = np.arange(0.0, duration + dt / 2, dt)
rng = np.random.default_rng(31)
spec = np.fft.rfft(rng.standard_normal(t.size))
f = np.fft.rfftfreq(t.size, dt)
spec[(f < 0.5) | (f > 15.0)] = 0.0
noise = np.fft.irfft(spec, t.size)
env = (t / 4.0) ** 2 * np.exp(2.0 * (1.0 - t / 4.0))
acc = noise * env
acc *= pga * G / np.max(np.abs(acc))
out = Path(__file__).parent / "site_motion_synthetic.csv"
np.savetxt(out, np.column_stack([t, acc]), delimiter=",", fmt="%.5f,%.6e",
           header="synthetic motion (examples/site_make_motion.py): time [s], acceleration [m/s^2]; PGA 0.15 g")
