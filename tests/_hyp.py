"""hypothesis for the property tests, or stand-ins that skip them when it is not installed.

The property tests import ``given``, ``settings``, ``st``, ... from here; without
hypothesis each ``@given`` test is skipped (with the reason) and every other test of the
module still runs.
"""

from __future__ import annotations

from typing import Any

import pytest

try:
    from hypothesis import HealthCheck, assume, given, settings
    from hypothesis import strategies as st
    from hypothesis.extra.numpy import arrays

    HAVE_HYPOTHESIS = True
except ImportError:  # pragma: no cover - exercised only without the test extra
    HAVE_HYPOTHESIS = False

    class _Anything:
        """Absorbs strategy construction at import time (``st.floats(...).map(...)``)."""

        def __getattr__(self, name: str) -> "_Anything":
            return self

        def __call__(self, *args: Any, **kwargs: Any) -> "_Anything":
            return self

        def __or__(self, other: Any) -> "_Anything":
            return self

        __ror__ = __or__

    st = HealthCheck = arrays = _Anything()

    def given(*args: Any, **kwargs: Any) -> Any:
        return pytest.mark.skip(reason="property test: hypothesis is not installed (pip install -e '.[test]')")

    def settings(*args: Any, **kwargs: Any) -> Any:
        return lambda f: f

    def assume(condition: Any) -> bool:
        return True

__all__ = ["HAVE_HYPOTHESIS", "HealthCheck", "arrays", "assume", "given", "settings", "st"]
