"""Batch work over datasets: a dataset directory in, a feature table out.

``features`` runs extraction on every trial (cached per trial, resumable, a bad
trial recorded and the rest kept), ``executors`` gives the same code a process
pool or a Dask cluster, ``inputs`` turns whatever ``predict`` is given into a
(λ, ω) table.
"""
