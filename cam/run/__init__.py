"""The whole chain in one command (``impeller-cam run``) and its Dask batch.

``run_chain`` runs geometry -> roughing -> finishing -> post -> verification ->
motion -> report for one spec into one folder (layout: docs/run.md); ``run_batch``
runs several specs in parallel on Dask; ``run_sweep`` makes design variants and runs
them on Dask without a shared filesystem (docs/sweep.md).
"""

from cam.run.batch import run_batch
from cam.run.chain import run_chain
from cam.run.record import STAGES
from cam.run.settings import RunSettings, resolve_settings
from cam.run.sweep import run_sweep

__all__ = ["STAGES", "RunSettings", "resolve_settings", "run_batch", "run_chain",
           "run_sweep"]
