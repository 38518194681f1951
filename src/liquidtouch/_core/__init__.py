"""The ground floor: what every stage shares, importing nothing of liquidtouch above it.

- :mod:`~liquidtouch._core.checks`: number checks (:func:`as_number`, range checks);
- :mod:`~liquidtouch._core.numbers`: numbers as text (a value rounded to its
  uncertainty), shared by the command line and the results' reprs;
- :mod:`~liquidtouch._core.atomic`: atomic writes (temp file, then rename) and
  deferred Ctrl-C while a write is swapped in;
- :mod:`~liquidtouch._core.progress`: the one progress bar (rich, stderr);
- :mod:`~liquidtouch._core.pool`: the worker pool (process pool or Dask) behind a
  ``concurrent.futures.Executor``;
- :mod:`~liquidtouch._core.liquids`, :mod:`~liquidtouch._core.containers`: the
  liquid and container catalogue that the simulator and the dataset labels read.

With :mod:`liquidtouch.errors` (the typed errors) this is layer 0 of
``docs/architecture.md``. Its modules are imported by their full path.
"""
