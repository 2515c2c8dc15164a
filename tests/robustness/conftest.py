"""The fuzzers draw the same examples whatever else the process has run.

Hypothesis (6.131 and later) mixes into its draws the literals of every
non-library module imported so far (``providers._get_local_constants``). A
derandomized fuzzer then draws other examples in a worker that ran other test
files first: the semantic fuzzer met a mechanism there that never appears
when it runs alone. With no such constants the examples depend only on the
test, as ``derandomize=True`` promises: a failure in CI is reproduced by
running the file alone.
"""

import pytest


@pytest.fixture(autouse=True)
def _no_local_constants(monkeypatch):
    try:
        from hypothesis.internal.conjecture import providers
    except ImportError:                 # pragma: no cover (a Hypothesis without providers)
        return
    if hasattr(providers, "_get_local_constants") and hasattr(providers, "Constants"):
        monkeypatch.setattr(providers, "_get_local_constants", providers.Constants)
        cache = getattr(providers, "CONSTANTS_CACHE", None)   # what earlier tests' draws kept
        if cache is not None:
            cache.cache.clear()
