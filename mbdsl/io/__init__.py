"""Results: the Solution of a run, and its files written and read back.

The format follows the file's extension: ``.h5``/``.hdf5`` is HDF5
(:mod:`mbdsl.io.hdf5`, the only module that imports h5py), anything else CSV
(:mod:`mbdsl.io.csvfile`). A file is self-contained (``metadata.py``): it
holds the model's source, so :func:`load_solution` rebuilds the model.

=============  =========================================================
module         holds
=============  =========================================================
solution.py    :class:`Solution`: the rows of a run, its columns, summary, warnings
rows.py        the row store of a running run, step statistics, extents
derived.py     derived columns: energies, reactions, outputs, sensors
metadata.py    what a file says besides its rows; the model rebuilt
stream.py      :class:`RowStream`: a file written as the run goes (an observer)
csvfile.py     CSV: write, stream, read back
hdf5.py        HDF5: write, stream, read back; sweep tables
=============  =========================================================
"""

from __future__ import annotations

from pathlib import Path

from .csvfile import CsvStream, read_csv_solution, write_csv
from .metadata import metadata, select_columns
from .solution import Solution
from .stream import RowStream

__all__ = ["Solution", "write_solution", "load_solution", "write_csv", "CsvStream", "RowStream",
           "metadata", "select_columns", "HDF5_SUFFIXES"]

#: The suffixes of HDF5 result files; anything else is CSV.
HDF5_SUFFIXES = (".h5", ".hdf5")


def write_solution(solution, path, extra_metadata: dict | None = None,
                   columns: list | None = None) -> Path:
    """Write a Solution, HDF5 for ``.h5``/``.hdf5``, else CSV; ``columns``:
    patterns of the columns to write (:func:`select_columns`), None: all.

    Raises
    ------
    OSError
        If the file cannot be written.
    ValueError
        A pattern of ``columns`` matches no column.
    """
    if Path(path).suffix.lower() in HDF5_SUFFIXES:
        from .hdf5 import write_hdf5
        return write_hdf5(solution, path, extra_metadata, columns)
    return write_csv(solution, path, extra_metadata, columns)


def load_solution(path):
    """Read a result file (CSV or HDF5, by extension) back into a Solution.

    Parameters
    ----------
    path : str or Path
        Written by ``mbdsl simulate -o`` or :func:`write_solution`.

    Returns
    -------
    Solution
        Equal to the written one: bit for bit from HDF5, and from CSV too
        (17 significant digits); the model is rebuilt from the stored source.

    Raises
    ------
    OSError
        The file cannot be read.
    ValueError
        Not a result file of this tool, or no model source in it.
    """
    path = Path(path)
    if path.suffix.lower() in HDF5_SUFFIXES:
        from .hdf5 import read_hdf5
        return read_hdf5(path)
    try:
        return read_csv_solution(path)
    except (KeyError, IndexError) as exc:
        raise ValueError(f"{path}: not a result file written by mbdsl "
                         f"(missing {exc})") from None
