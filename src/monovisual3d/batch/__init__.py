"""Many sessions at once on a Dask cluster: one table of fruit, one table of sessions, nothing lost.

Quick use::

    from monovisual3d import batch
    fruit, sessions = batch.run(["runs/"], "out/", method="paper", workers=2)   # pandas DataFrames

Needs the ``dask`` extra (``pip install 'monovisual3d[dask]'``): dask.distributed,
pandas and pyarrow. See ``docs/batch.md`` for the tables' columns. :func:`.spread.spread_map`
spreads other independent work (benchmark seeds, reproduction runs) over the same kind of cluster.
"""

from __future__ import annotations

from .inputs import SESSION_NAMES, TRUTH_NAME, SessionInput, find_sessions
from .run import DEFAULT_MAX_WORKER_DEATHS, BatchProgress, BatchTables, run
from .tables import FRUIT_COLUMNS, SESSION_COLUMNS, TRANSIENT_ERRORS, read_tables
from .work import Job, config_hash, run_job

__all__ = [
    "DEFAULT_MAX_WORKER_DEATHS",
    "FRUIT_COLUMNS",
    "SESSION_COLUMNS",
    "SESSION_NAMES",
    "TRANSIENT_ERRORS",
    "TRUTH_NAME",
    "BatchProgress",
    "BatchTables",
    "Job",
    "SessionInput",
    "config_hash",
    "find_sessions",
    "read_tables",
    "run",
    "run_job",
]
