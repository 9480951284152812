"""Input ground motions for a site-response run: PEER AT2 files and two-column tables.

* ``"peer"``: the PEER NGA ``.AT2`` format -- four header lines (title, event and
  station, ``ACCELERATION TIME SERIES IN UNITS OF G``, then ``NPTS= n, DT= dt SEC``
  or ``n dt NPTS, DT``), then the accelerations, several per line. The units come from
  the third line (``G``, ``CM/S/S``, ``CM/S^2``, ``M/S/S``, ``M/S^2``); a ``units``
  given in the profile must agree with them.
* ``"two-column"``: time [s] and acceleration per line (comma, space or tab separated;
  lines starting with ``#`` and one text header line are skipped); the time step must be
  uniform (to 1e-6 of the step) and the units are given by the profile
  (``[motion] units``).

Accelerations are returned in g (standard gravity 9.80665 m/s^2), the unit pystrata's
``TimeSeriesMotion`` takes.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from grainmech.errors import ConfigError
from grainmech.io.config import read_text_file

__all__ = ["Motion", "read_motion", "MOTION_UNITS"]

#: accepted acceleration units -> factor to g
MOTION_UNITS = {"g": 1.0, "m/s^2": 1.0 / 9.80665, "cm/s^2": 0.01 / 9.80665, "gal": 0.01 / 9.80665}
#: unit names of an AT2 header line -> key of MOTION_UNITS
_AT2_UNITS = {"G": "g", "CM/S/S": "cm/s^2", "CM/S^2": "cm/s^2", "CM/SEC/SEC": "cm/s^2", "M/S/S": "m/s^2",
              "M/S^2": "m/s^2", "GAL": "gal"}
#: relative tolerance on the time step of a two-column motion
DT_TOLERANCE = 1e-6


@dataclass(frozen=True)
class Motion:
    """A ground motion: ``time_step`` [s], ``accel_g`` (n,) [g], ``description``, ``source`` (file name)."""

    time_step: float
    accel_g: np.ndarray
    description: str
    source: str

    @property
    def pga_g(self) -> float:
        """Peak ground acceleration [g]."""
        return float(np.max(np.abs(self.accel_g)))

    @property
    def duration(self) -> float:
        """Duration [s]."""
        return self.time_step * (len(self.accel_g) - 1)


def _bad(path: Path, problem: str) -> ConfigError:
    return ConfigError("motion.file", str(path), problem)


def _read_at2(path: Path, text: str, units: str | None) -> Motion:
    lines = text.splitlines()
    if len(lines) < 5:
        raise _bad(path, "not a PEER AT2 file (fewer than 5 lines)")
    head = lines[3].upper()
    m_n = re.search(r"NPTS\s*=\s*(\d+)", head)
    m_dt = re.search(r"DT\s*=\s*([0-9.EeDd+-]+)", head)
    if m_n and m_dt:
        n, dt_text = int(m_n.group(1)), m_dt.group(1)
    else:
        parts = head.replace(",", " ").split()
        if len(parts) < 2 or "NPTS" not in head:
            raise _bad(path, f"line 4 {lines[3].strip()!r} gives neither 'NPTS= n, DT= dt' nor 'n dt NPTS, DT'")
        try:
            n, dt_text = int(float(parts[0])), parts[1]
        except (ValueError, OverflowError):
            raise _bad(path, f"line 4 {lines[3].strip()!r}: cannot read the number of points and the time step "
                       "('NPTS= n, DT= dt' or 'n dt NPTS, DT')") from None
    try:
        dt = float(dt_text.replace("D", "E").replace("d", "e"))
    except ValueError:
        raise _bad(path, f"line 4: cannot read the time step {dt_text!r}") from None
    _check_time_step(path, dt, "line 4: the time step")
    found = next((u for name, u in sorted(_AT2_UNITS.items(), key=lambda kv: -len(kv[0]))
                  if re.search(rf"UNITS OF {re.escape(name)}\b", lines[2].upper())), None)
    if found is None and units is None:
        raise _bad(path, f"line 3 {lines[2].strip()!r} names no known acceleration units; give motion.units")
    if found is not None and units is not None and MOTION_UNITS[found] != MOTION_UNITS[units]:
        raise ConfigError("motion.units", units, f"the AT2 header of {path} says {found}")
    try:
        acc = np.array([float(v.replace("D", "E")) for ln in lines[4:] for v in ln.replace(",", " ").split()])
    except ValueError as exc:
        raise _bad(path, f"a value is not a number ({exc})") from None
    if acc.size != n:
        raise _bad(path, f"the header says NPTS = {n} but the file has {acc.size} values")
    unit = found or units or "g"
    return _checked(Motion(dt, acc * MOTION_UNITS[unit], lines[1].strip(), path.name), path)


def _read_two_column(path: Path, text: str, units: str) -> Motion:
    t: list[float] = []
    a: list[float] = []
    lineno: list[int] = []
    header_skipped = False
    for k, raw in enumerate(text.splitlines(), start=1):
        s = raw.strip()
        if not s or s.startswith("#"):
            continue
        parts = s.replace(",", " ").split()
        try:
            vals = [float(p) for p in parts]
        except ValueError:
            if not t and not header_skipped:
                header_skipped = True
                continue
            raise _bad(path, f"line {k}: {s!r} is not two numbers (time [s], acceleration)") from None
        if len(vals) != 2:
            raise _bad(path, f"line {k}: {len(vals)} values, expected 2 (time [s], acceleration)")
        t.append(vals[0])
        a.append(vals[1])
        lineno.append(k)
    if len(t) < 8:
        raise _bad(path, f"{len(t)} samples: too short for a motion")
    tt = np.asarray(t)
    if not np.all(np.isfinite(tt)):
        i = int(np.flatnonzero(~np.isfinite(tt))[0])
        raise _bad(path, f"line {lineno[i]}: time {t[i]!r} is not finite")
    d = np.diff(tt)
    back = np.flatnonzero(d <= 0)
    if back.size:
        i = int(back[0]) + 1
        raise _bad(path, f"line {lineno[i]}: time {float(tt[i]):.10g} s does not increase (the previous sample is at "
                   f"{float(tt[i - 1]):.10g} s): times must increase monotonically")
    dt = float(d[0])
    if not dt > 0:
        raise _bad(path, f"line {lineno[1]}: time {float(tt[1]):.10g} s does not increase")
    _check_time_step(path, dt, f"line {lineno[1]}: the time step")
    bad = np.flatnonzero(np.abs(d - dt) > DT_TOLERANCE * dt)
    if bad.size:
        i = int(bad[0]) + 1
        raise _bad(path, f"non-uniform time step: line {lineno[i]} (t = {float(tt[i]):.10g} s) is "
                   f"{float(d[i - 1]):.10g} s after the previous sample, the first step is {dt:.10g} s")
    return _checked(Motion(dt, np.asarray(a) * MOTION_UNITS[units], f"{path.name} ({units})", path.name), path,
                    lineno)


#: time steps of a motion [s]: strong-motion records are sampled at 50-1000 Hz (0.001-0.02 s)
TIME_STEP_RANGE = (1e-5, 1.0)
#: fewest samples of a motion
MIN_SAMPLES = 8
#: largest acceleration of a motion [g]: the largest recorded peak ground accelerations are about 4 g
MAX_ACCEL_G = 10.0


def _check_time_step(path: Path, dt: float, what: str) -> None:
    lo, hi = TIME_STEP_RANGE
    if not (np.isfinite(dt) and lo <= dt <= hi):
        raise _bad(path, f"{what} {dt!r} s must lie in [{lo:g} s, {hi:g} s] (records are sampled at 1 Hz to 100 kHz)")


def _checked(m: Motion, path: Path, lineno: list[int] | None = None) -> Motion:
    """``m`` if it has enough samples, all finite and within :data:`MAX_ACCEL_G` (errors name the sample)."""
    a = m.accel_g
    if a.size < MIN_SAMPLES:
        raise _bad(path, f"{a.size} sample(s): too short for a motion (at least {MIN_SAMPLES})")
    bad = np.flatnonzero(~np.isfinite(a) | (np.abs(a) > MAX_ACCEL_G))
    if bad.size:
        i = int(bad[0])
        where = f"line {lineno[i]}" if lineno is not None else f"value {i + 1}"
        what = ("is not finite" if not np.isfinite(a[i])
                else f"is {a[i]:.4g} g, above {MAX_ACCEL_G:g} g (check the units)")
        raise _bad(path, f"{where}: the acceleration {what}")
    return m


def read_motion(path: str | Path, format: str, units: str | None) -> Motion:
    """Read a ground motion (see the module docstring); errors name ``motion.file`` or ``motion.units``.

    Parameters
    ----------
    path : path
    format : {"peer", "two-column"}
    units : str or None
        One of :data:`MOTION_UNITS` (required for ``"two-column"``).
    """
    p = Path(path)
    if units is not None and units not in MOTION_UNITS:
        raise ConfigError("motion.units", units, f"unknown acceleration units: must be one of {list(MOTION_UNITS)}")
    try:
        text = read_text_file(p, "motion")
    except ConfigError:
        raise
    except Exception as exc:  # noqa: BLE001 (missing file, directory, encoding: one line naming the key)
        raise _bad(p, str(exc)) from None
    if format == "peer":
        return _read_at2(p, text, units)
    if format == "two-column":
        if units is None:
            raise ConfigError("motion.units", None, f"a two-column motion needs its units, one of {list(MOTION_UNITS)}")
        return _read_two_column(p, text, units)
    raise ConfigError("motion.format", format, "must be 'peer' or 'two-column'")
