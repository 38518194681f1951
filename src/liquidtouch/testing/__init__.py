"""What the tests and the benchmarks share (like ``numpy.testing``): synthetic tables,
marker tracks without rendering, videos in each recording format, the headless-Chromium
checks of the report and the live page, and runs of ``live`` on the simulated rig.

- :mod:`~liquidtouch.testing.synthetic_tables`: (λ, ω) feature tables from the sloshing
  formulas, shaped like the paper's experiments;
- :mod:`~liquidtouch.testing.experiment_tables`: the seven experiments' feature tables;
- :mod:`~liquidtouch.testing.scene_tracks`: a simulated scene's marker tracks plus noise;
- :mod:`~liquidtouch.testing.video_formats`: rendered frames written as each recording
  format writes them;
- :mod:`~liquidtouch.testing.chromium`, :mod:`~liquidtouch.testing.report_page`,
  :mod:`~liquidtouch.testing.live_page`: headless Chromium, what the report and the live
  page show in it;
- :mod:`~liquidtouch.testing.rig_runs`: ``rig serve``, ``run-trial`` and ``live`` together.

Not part of the estimation API: nothing in the pipeline imports it. The package itself
gives the benchmarks the commands' progress bar (:func:`progress_bar`: rich, on stderr,
only on a terminal).
"""

from liquidtouch._core.progress import progress_bar

__all__ = ["progress_bar"]
