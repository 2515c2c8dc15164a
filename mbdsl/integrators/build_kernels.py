"""The kernels' build as a process of its own: ``python -m
mbdsl.integrators.build_kernels`` compiles every kernel for this machine,
writes the cache's marker and drops the build lock
(:func:`.kernel_cache.start_background_build` starts it detached; run by
hand, it builds in the foreground).
"""

from __future__ import annotations

import sys

__all__ = ["main"]


def main() -> int:
    """Compile (or load) every kernel, write the marker, drop the lock; the
    exit status (0)."""
    from mbdsl.integrators import kernel_cache
    try:
        kernel_cache.ensure_loaded()
        return 0
    finally:
        try:
            kernel_cache._lock().unlink(missing_ok=True)
        except OSError:
            pass


if __name__ == "__main__":
    sys.exit(main())
