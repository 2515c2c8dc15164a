"""Writing solutions to files.

CSV: ``#`` metadata lines (model file and its SHA-256, method and its
parameters, h, t_end, tool version, run status), then a header row of column
names and one row per stored time point, every value with 17 significant
digits so that a CSV round trip loses nothing.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

__all__ = ["write_csv", "read_csv_metadata"]


def _metadata(solution, extra: dict | None) -> dict:
    from . import __version__
    model = solution.model
    meta = {
        "mbdsl_version": __version__,
        "model": model.name,
        "model_file": model.file,
        "model_sha256": model.sha256,
        "method": solution.method_name,
    }
    meta.update({f"method.{k}": repr(float(v)) for k, v in solution.method_parameters.items()})
    meta.update({"h": repr(solution.h), "t_end": repr(solution.t_end),
                 "status": solution.status, "message": solution.message.replace("\n", " ")})
    if model.parameters:
        meta["parameters"] = ", ".join(f"{k}={float(v)!r}" for k, v in model.parameters.items())
    meta.update(extra or {})
    return meta


def write_csv(solution, path, extra_metadata: dict | None = None) -> Path:
    """Write a Solution as CSV.

    Parameters
    ----------
    solution : Solution
    path : str or Path
    extra_metadata : dict, optional
        More ``# key: value`` lines.

    Returns
    -------
    Path
        The file written.

    Raises
    ------
    OSError
        If the file cannot be written.
    """
    path = Path(path)
    names, values = solution.table()
    buf = io.StringIO()
    for k, v in _metadata(solution, extra_metadata).items():
        buf.write(f"# {k}: {v}\n")
    buf.write(",".join(names) + "\n")
    np.savetxt(buf, values, fmt="%.17g", delimiter=",")
    path.write_text(buf.getvalue(), encoding="utf-8")
    return path


def read_csv_metadata(path) -> tuple[dict, list[str], np.ndarray]:
    """Read a CSV written by :func:`write_csv`: (metadata, column names, values)."""
    meta, header, rows = {}, None, []
    with open(path, encoding="utf-8") as f:
        for line in f:
            if line.startswith("#"):
                key, _, value = line[1:].strip().partition(": ")
                meta[key] = value
            elif header is None:
                header = line.strip().split(",")
            elif line.strip():
                rows.append([float(x) for x in line.split(",")])
    return meta, header or [], np.array(rows).reshape(len(rows), len(header or []))
