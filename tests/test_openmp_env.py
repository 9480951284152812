"""OpenMP waiting of the compiled kernels' threads: the defaults `import grainmech` sets.

Passive waiting with a short spin (``GOMP_SPINCOUNT=1000``): ``docs/performance.md``,
"Waiting threads" (measured: 10 % faster on an idle machine than no spin, as fast with
a core taken by another process; longer spins were up to 40 % slower there). A value
the user set is kept, and a spin count is never added to a policy the user chose (it
would override ``ACTIVE``'s own).
"""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

_PROBE = "import os, grainmech; print(os.environ.get('OMP_WAIT_POLICY'), os.environ.get('GOMP_SPINCOUNT'))"


def _probe(**env: str) -> str:
    clean = {k: v for k, v in os.environ.items() if k not in ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT")}
    out = subprocess.run([sys.executable, "-c", _PROBE], env={**clean, **env}, capture_output=True,
                         text=True, check=True)
    return out.stdout.strip()


@pytest.mark.parametrize(("env", "expected"), [
    ({}, "PASSIVE 1000"),
    ({"OMP_WAIT_POLICY": "ACTIVE"}, "ACTIVE None"),
    ({"OMP_WAIT_POLICY": "PASSIVE"}, "PASSIVE None"),
    ({"GOMP_SPINCOUNT": "0"}, "PASSIVE 0"),
])
def test_import_sets_passive_waiting_with_a_short_spin_unless_set(env, expected):
    assert _probe(**env) == expected
