"""Studies: the paper's experiments (convergence, energy, drift, cost,
work-precision) on any model, run in parallel, written as tables and figures.

Entry point: :func:`run_study` (``mbdsl study`` on the command line).
"""

from .parallel import default_jobs, run_specs
from .reference import StudyReference, build_reference, method_order
from .runs import ModelSource, RunData, RunSpec, execute_run
from .study import (KINDS, Section, StudyOptions, StudyResult, fitted_order, parse_h_range,
                    quantity_error, run_study)
from .tables import Table

__all__ = ["KINDS", "StudyOptions", "StudyResult", "Section", "Table", "run_study",
           "parse_h_range", "fitted_order", "quantity_error", "StudyReference",
           "build_reference", "method_order", "ModelSource", "RunSpec", "RunData",
           "execute_run", "run_specs", "default_jobs"]
