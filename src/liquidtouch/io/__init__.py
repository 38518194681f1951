"""Input and output: where data enters and leaves the pipeline.

Takes files and devices; gives arrays and validated records. Frame sources
(video files through PyAV, image folders, cameras) with real timestamps; the
trial and dataset formats (``meta.json``, ``manifest.csv``, every trial-directory
file name and schema); signal CSVs; feature tables; atomic writes. Nothing here
analyses data. The formats are documented in ``docs/formats.md``.

This package exports the trial, dataset and signal-CSV readers; the frame
sources (``iter_frames``, ``read_frames``) are exported by
:mod:`liquidtouch.io.frames` itself, so that what imports ``liquidtouch.io``
(the models layer reads feature tables through it) does not reach PyAV or OpenCV.
"""

from liquidtouch.io.dataset import TrialMeta, read_manifest, read_trial_meta
from liquidtouch.io.signal_csv import read_signal_csv, write_signal_csv

__all__ = [
    "TrialMeta",
    "read_manifest",
    "read_signal_csv",
    "read_trial_meta",
    "write_signal_csv",
]
