"""The whole chain in one command (``impeller-cam run``) and its Dask batch.

``run_chain`` runs geometry -> roughing -> finishing -> post -> verification ->
motion -> report for one spec into one folder (layout: docs/run.md); ``run_batch``
runs several specs (design variants) in parallel on Dask.
"""

from cam.run.batch import run_batch
from cam.run.chain import run_chain
from cam.run.record import STAGES
from cam.run.settings import RunSettings, resolve_settings

__all__ = ["STAGES", "RunSettings", "resolve_settings", "run_batch", "run_chain"]
