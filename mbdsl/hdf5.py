"""HDF5 results (h5py): the only module that imports h5py.

Layout of a file written by :func:`write_hdf5` (N stored time points, n
coordinates, m constraint rows)::

    /                       attrs: every key of mbdsl.output.metadata (str)
    /t                      (N,)      [s]
    /q  /v  /a              (N, n)    attrs["columns"]: coordinate names
    /lambda                 (N, m)    attrs["columns"]: lambda.<joint>.<row>
    /extras/<mu|psi1>       (N, m)    the method's further multipliers
    /energies               (N, 6)    kinetic, potential, total, work, dissipated, balance [J]
    /constraints            (N, 2)    max |Phi| [m], max |Phi_q v + Phi_t| [m/s]
    /reactions              (N, 3 J + D)  fx, fy [N], torque [N m] per joint, then the
                            driver loads driver.<name>.force|torque and the
                            outputs output.<name>
    /newton                 (N, 5)    iterations, residuals, jacobians,
                                      factorizations, h of each step
    /model_source           str       the .mbd text (also an attribute)
    /metadata               (bytes,)  uint8: UTF-8 JSON {"attributes": the root
                                      attributes, "columns": dataset -> column names}

Every dataset carries its column names in ``attrs["columns"]``. Arrays are
stored as float64/int64 as computed, so :func:`read_hdf5` returns a
Solution equal to the written one bit for bit.

Damage is detected, not read as results: the file is written with the
newest format (``libver="latest"``: checksums on the superblock and every
object header), each non-empty dataset with the Fletcher-32 checksum filter,
and the metadata and column names, whose strings HDF5 keeps in its global
heap without a checksum, also as the checked ``/metadata`` record, which is
what :func:`read_hdf5` reads. A byte changed in what it reads makes it raise
instead of returning other numbers (or, in the global heap, making the HDF5
library loop, as damaged files of older versions can).
"""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np

__all__ = ["write_hdf5", "read_hdf5", "update_attributes"]


def _dataset(group, name, data, columns=None):
    """A dataset with the Fletcher-32 checksum (chunked) when it has values,
    and its column names in ``attrs["columns"]`` when given."""
    data = np.asarray(data)
    ds = group.create_dataset(name, data=data, fletcher32=bool(data.size))
    if columns is not None:
        ds.attrs["columns"] = np.array(columns, dtype=h5py.string_dtype())
    return ds


def _write_record(f, record: dict) -> None:
    """The checked copy of the metadata and column names: ``/metadata``, the
    record as UTF-8 JSON in a uint8 dataset under the Fletcher-32 checksum
    (replaced whole when it exists)."""
    if "metadata" in f:
        del f["metadata"]
    _dataset(f, "metadata", np.frombuffer(json.dumps(record).encode("utf-8"), dtype=np.uint8))


def write_hdf5(solution, path, extra_metadata: dict | None = None) -> Path:
    """Write a Solution as HDF5 (layout in the module docstring).

    Parameters
    ----------
    solution : Solution
    path : str or Path
    extra_metadata : dict, optional
        More root attributes.

    Returns
    -------
    Path

    Raises
    ------
    OSError
        If the file cannot be written.
    """
    from .output import metadata
    path = Path(path)
    sol, lay = solution, solution.system.layout
    derived = sol.derived()
    meta = metadata(sol, extra_metadata)
    columns = {}

    def table(group, name, data, names):
        """A dataset of named columns, its names also kept for the record."""
        columns[f"{group.name.strip('/')}/{name}".strip("/")] = list(names)
        return _dataset(group, name, data, names)

    with h5py.File(path, "w", libver="latest") as f:
        for k, v in meta.items():
            f.attrs[k] = v
        _dataset(f, "t", sol.t)
        table(f, "q", sol.q, lay.coordinates)
        table(f, "v", sol.v, lay.velocities)
        table(f, "a", sol.a, lay.accelerations)
        table(f, "lambda", sol.lam, lay.multiplier_names())
        extras = f.create_group("extras")
        for x in sol.extra_names:
            table(extras, x, sol.extras[x], [f"{x}.{a}.{b}" for a, b in lay.rows])
        energies = [k for k in sol.DERIVED_NAMES if k.startswith("energy.")]
        table(f, "energies", np.column_stack([derived[k] for k in energies]), energies)
        cons = ["constraint.position", "constraint.velocity"]
        table(f, "constraints", np.column_stack([derived[k] for k in cons]), cons)
        reac = [k for k in derived if k.startswith(("reaction.", "driver.", "output."))]
        table(f, "reactions", np.column_stack([derived[k] for k in reac])
              if reac else np.zeros((len(sol.t), 0)), reac)
        grp = f.create_group("newton")
        for k in sol.STAT_NAMES:                 # ints stay ints, h stays float
            _dataset(grp, k, sol.stats[k])
        f.create_dataset("model_source", data=sol.model.source or "",
                         dtype=h5py.string_dtype())
        _write_record(f, {"attributes": meta, "columns": columns})
    return path


def update_attributes(path, attrs: dict) -> None:
    """Replace root attributes (str -> str) of a result file written by
    :func:`write_hdf5`, and their checked copy in ``/metadata``.

    Raises
    ------
    OSError
        If the file cannot be opened for writing.
    """
    with h5py.File(path, "a") as f:
        for k, v in attrs.items():
            f.attrs[k] = v
        if "metadata" in f:
            record = json.loads(bytes(f["metadata"][()]).decode("utf-8"))
            record["attributes"].update(attrs)
            _write_record(f, record)


def _columns(ds) -> list[str]:
    return [c.decode() if isinstance(c, bytes) else str(c) for c in ds.attrs["columns"]]


def read_hdf5(path):
    """A Solution from a file written by :func:`write_hdf5`.

    Raises
    ------
    OSError
        Not an HDF5 file, or unreadable.
    ValueError
        An HDF5 file that is not an mbdsl result, or a damaged one (a
        checksum that does not match, a missing or unreadable part).
    """
    path = Path(path)
    with h5py.File(path, "r") as f:
        try:
            return _read(f, path)
        except (OSError, KeyError, RuntimeError, TypeError, IndexError,
                json.JSONDecodeError) as exc:
            raise ValueError(f"{path}: the file is damaged ({exc}); its results cannot be "
                             "trusted: write it again with mbdsl simulate") from None


def _read(f, path):
    """The Solution of the open result file ``f`` (:func:`read_hdf5`)."""
    from .output import _method_parameters, _run_stats, rebuild_system, run_description
    from .solution import Solution
    if "metadata" in f:           # the checked copy; the attributes are not read
        record = json.loads(bytes(f["metadata"][()]).decode("utf-8"))
        meta, columns = record["attributes"], record["columns"]
    else:                         # a file of an older version: its attributes
        meta = {k: (v.decode() if isinstance(v, bytes) else str(v)) for k, v in f.attrs.items()}
        columns = None
    if "method" not in meta or "q" not in f:
        raise ValueError(f"{path}: an HDF5 file, but not a result written by mbdsl")
    system = rebuild_system(meta, path)
    derived = {}
    for name in ("energies", "constraints", "reactions"):
        values = f[name][()]
        names = columns[name] if columns is not None else _columns(f[name])
        derived.update({c: values[:, i] for i, c in enumerate(names)})
    extra_names = json.loads(meta.get("extras", "[]"))
    return Solution.from_arrays(
        system, method_name=meta["method"], method_parameters=_method_parameters(meta),
        extra_names=extra_names, h=float(meta["h"]), t_end=float(meta["t_end"]),
        t=f["t"][()], q=f["q"][()], v=f["v"][()], a=f["a"][()], lam=f["lambda"][()],
        extras={x: f["extras"][x][()] for x in extra_names},
        stats={k: f["newton"][k][()] for k in Solution.STAT_NAMES},
        stats_total=_run_stats(meta), status=meta.get("status", "completed"),
        message=meta.get("message", ""), wall_time=float(meta.get("wall_time", 0.0)),
        derived=derived, **run_description(meta))
