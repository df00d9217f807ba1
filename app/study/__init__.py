"""Study-wide analysis: every trial's metrics and every patient's progress table over a
study's thousands of trial files, computed on Dask (issue 32).

One console analyses one trial at a time, in its own process; a study of hundreds of
patients needs many processes, on one machine or on a cluster. The work per trial is the
console's own (app.trials.reader, app.trials.analysis): this package only hands it out and
gathers it, so a study's figures are the console's figures, never a formula of its own.

* app.study.sources: what to analyse, a folder of trial files or the data folder's
  registry (a patient, or every patient), the trials marked invalid left out unless asked;
* app.study.schema: the result's columns and their types, fixed before any file is read
  (a Dask dataframe needs them up front);
* app.study.rows: one trial file's row, computed in a worker process that opens the file
  itself (h5py is not thread-safe: a worker has one thread);
* app.study.cluster: a local cluster (two worker processes, on 127.0.0.1 only, no
  dashboard) or a scheduler's address;
* app.study.run: the researcher's API (`study_frame`, a Dask dataframe; `analyse_study`,
  the computed rows and the failures with their reasons);
* app.study.outputs: Parquet (partitioned by patient or site) and CSV, written guarded and
  atomically, never over what a data folder owns.

Dask, pandas, pyarrow and DuckDB are imported only here (and by the `rehab study` command).
"""
