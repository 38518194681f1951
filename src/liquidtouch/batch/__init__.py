"""Batch work over datasets: a dataset directory in, a feature table out.

``features`` runs extraction on every trial (cached per trial, resumable, a bad
trial recorded and the rest kept) on the worker pool of
:mod:`liquidtouch._core.pool` (processes or a Dask cluster), ``inputs`` turns
whatever ``predict`` is given into a (λ, ω) table.
"""

from liquidtouch.batch.features import extract_features

__all__ = ["extract_features"]
