"""Input and output: where data enters and leaves the pipeline.

Takes files and devices; gives arrays and validated records. Frame sources
(video files through PyAV, image folders, cameras) with real timestamps; the
trial and dataset formats (``meta.json``, ``manifest.csv``, every trial-directory
file name and schema); signal CSVs; feature tables; atomic writes. Nothing here
analyses data. The formats are documented in ``docs/formats.md``.
"""
