"""Which kernels this process can call: numba's cache marker, the kernels
loaded here, and the uncompiled copy.

The element kernels are evaluated outside a time loop too (the assembled
system's Phi, Q and their derivatives, the initial conditions, the output):
on the compiled kernels once this process has loaded them or the machine's
cache holds them, else on their uncompiled copy, so that nothing waits on a
compilation it did not announce (:func:`element_kernels`). Building the
kernels, announced and timed, is :mod:`mbdsl.integrators.kernel_cache`'s.

Whether the kernels are built is recorded by a marker file beside numba's
cache, keyed by the sources of both kernel packages (``kernel_sources``),
numba's version and the host CPU (:func:`kernels_ready`).
"""

from __future__ import annotations

import functools
import hashlib
import importlib
import json
import re
import sys
import time
import types
from pathlib import Path

from . import UNCOMPILED_ROOT

__all__ = ["KERNEL_PACKAGES", "kernel_sources", "source_digest", "kernels_ready",
           "build_in_progress", "loaded", "element_kernels", "import_uncompiled", "package_root"]

#: The packages of numba code (folders under ``mbdsl``): the element kernels and the
#: step kernels.
KERNEL_PACKAGES = ("kernels", "integrators/compiled")
#: The files besides them that say which kernels a build compiles (the warm-up).
_BUILD_FILES = ("integrators/kernel_cache.py", "integrators/warm_up.py")
#: A build lock older than this is taken to belong to a dead build [s].
_STALE_LOCK = 900.0

_loaded: set = set()          # entry-point groups loaded in this process (kernel_cache.GROUPS)


def package_root() -> Path:
    """The folder that holds the ``mbdsl`` package this process imported
    (site-packages, or a source checkout)."""
    return Path(__file__).resolve().parents[2]


def kernel_sources() -> list:
    """Every source file of the numba code (``KERNEL_PACKAGES``), sorted.

    numba's on-disk cache keys a function on its own file only: a kernel that
    calls a changed kernel of another file loads its stale machine code
    (numba issue #1833). The marker's key therefore covers all of them, and a
    change of any one rebuilds every kernel (``kernel_cache.ensure_loaded``).
    """
    root = package_root() / "mbdsl"
    return sorted(p for package in KERNEL_PACKAGES for p in (root / package).rglob("*.py"))


def loaded() -> bool:
    """Whether this process has loaded (or compiled) the kernels of a group:
    output that can use them (``engine.index1_multipliers``) then does,
    without ever starting a compilation of its own."""
    return bool(_loaded)


def _cache_dir() -> Path:
    """The folder numba caches the element kernels in (the marker and the lock live there)."""
    from . import api
    try:
        return Path(api.elements._cache._cache_path)
    except AttributeError:          # numba moved its internals: a folder of our own
        import os
        base = os.environ.get("NUMBA_CACHE_DIR") or Path.home() / ".cache" / "mbdsl"
        return Path(base)


#: ``from mbdsl.<module> import <names>`` in a kernel source (the values the numba code
#: reads from the rest of mbdsl: opcodes, recipe fields, outcome codes, record places)
_ABSOLUTE_IMPORT = re.compile(rb"^\s*from\s+(mbdsl\.[\w.]+)\s+import\s+(\([^)]*\)|[^\n]*)", re.M)


def imported_values(sources: dict) -> list:
    """``module.name=repr(value)`` of every name the kernel sources import from
    the rest of mbdsl, sorted.

    numba freezes a global's value into the machine code it caches, and its
    cache sees only the function's own file: a changed opcode, recipe field
    or record place imported from ``mbdsl.integrators.records`` would leave
    the cached kernels reading the old one. The digest covers these values,
    so such a change rebuilds the kernels as a change of their own files
    does (and a change elsewhere in those modules does not).

    Parameters
    ----------
    sources : dict of str -> bytes
        The kernel sources' texts.
    """
    out = set()
    for text in sources.values():
        for module, names in _ABSOLUTE_IMPORT.findall(text):
            module = module.decode()
            if any(module.startswith("mbdsl." + p.replace("/", ".")) for p in KERNEL_PACKAGES):
                continue
            values = importlib.import_module(module)
            names = re.sub(rb"#[^\n]*", b"", names).strip(b"() \n")
            for item in names.split(b","):       # "name" or "name as alias"
                if not item.strip():
                    continue
                name = item.split()[0].decode()
                value = getattr(values, name)
                if callable(value):      # a function's repr holds its address: its name
                    value = f"<{getattr(value, '__qualname__', type(value).__name__)}>"
                out.add(f"{module}.{name}={value!r}")
    return sorted(out)


def source_digest() -> str:
    """The engine's version: the SHA-256 of every kernel source, of the values
    they import from the rest of mbdsl (:func:`imported_values`) and of the
    warm-up that says which of them a build compiles (hex, 64 digits). It
    changes with any change of the numba code, and nothing else; results
    that record it (``docs/studies``) say which engine computed them.

    Computed once per process and package root: reading and scanning the
    sources costs 3.4 ms, which every assembled system paid when it asked
    whether the kernels are built (a sweep assembles one per point), and a
    process runs the kernels it imported, whatever the files say later."""
    return _digest(package_root())


@functools.lru_cache(maxsize=None)
def _digest(root: Path) -> str:
    """:func:`source_digest` of the package under ``root``."""
    digest = hashlib.sha256()
    sources = {path: path.read_bytes() for path in kernel_sources()}
    for path in list(sources) + [root / "mbdsl" / name for name in _BUILD_FILES]:
        text = sources[path] if path in sources else path.read_bytes()
        digest.update(str(path.relative_to(root)).encode() + b"\0" + text + b"\0")
    for value in imported_values(sources):
        digest.update(value.encode() + b"\0")
    return digest.hexdigest()


def _key() -> dict:
    """What the cached kernels depend on: our sources (:func:`source_digest`),
    numba, the host CPU."""
    from . import jit
    return {"source": source_digest(),
            "numba": jit.version(), "cpu": jit.host_cpu(),
            "python": sys.version.split()[0]}


def _marker() -> Path:
    return _cache_dir() / "mbdsl-kernels.json"


def _lock() -> Path:
    return _cache_dir() / "mbdsl-kernels.lock"


def kernels_ready() -> bool:
    """True when every kernel is in numba's cache for this machine (imports numba).

    Returns False, never raises, when numba is missing or the cache folder
    cannot be read.
    """
    try:
        return json.loads(_marker().read_text()) == _key()
    except (OSError, ValueError, ImportError):
        return False


def build_in_progress() -> bool:
    """True while a background build holds the lock (and is not stale)."""
    try:
        return time.time() - _lock().stat().st_mtime < _STALE_LOCK
    except (OSError, ImportError):
        return False


def import_uncompiled(name: str):
    """A kernel package imported a second time with numba's JIT disabled, as
    ``UNCOMPILED_ROOT + "." + name`` (``name``: ``"kernels.api"`` or
    ``"integrators.compiled"``).

    numba's ``DISABLE_JIT`` makes ``njit`` return the function itself. The
    kernels import each other relatively, so the copy's modules see the copy;
    what they import from the rest of mbdsl (absolute imports: opcodes,
    recipe fields, outcomes) is shared. The copy's parent packages are empty
    shells: importing them runs no ``__init__`` of mbdsl. This process's
    compiled kernels are untouched, and not imported by this function.

    Returns
    -------
    module
        Cached in ``sys.modules`` for the rest of the process.

    Raises
    ------
    ImportError
        numba is not installed (its switch is needed), or the package fails.
    """
    full = f"{UNCOMPILED_ROOT}.{name}"
    module = sys.modules.get(full)
    if module is not None:
        return module
    from .jit import jit_disabled
    root = package_root() / "mbdsl"
    shells = {UNCOMPILED_ROOT: root, UNCOMPILED_ROOT + ".integrators": root / "integrators"}
    for shell_name, folder in shells.items():
        if shell_name not in sys.modules:
            shell = types.ModuleType(shell_name)
            shell.__path__ = [str(folder)]
            sys.modules[shell_name] = shell
    before = set(sys.modules)
    try:
        with jit_disabled():
            return importlib.import_module(full)
    except BaseException:
        for added in set(sys.modules) - before:
            del sys.modules[added]
        raise


def element_kernels(uncompiled: bool = False):
    """The element kernels' entry points (:mod:`.api`): compiled, or with
    ``uncompiled`` their copy run by the interpreter (:func:`import_uncompiled`)."""
    if uncompiled:
        return import_uncompiled("kernels.api")
    return importlib.import_module("mbdsl.kernels.api")
