"""Where runs happen: ``simulate`` (validate, then step a method, in a worker process where the
engine may abort or hang), ``isolation`` (forkserver workers and the reused worker pool, a crash
or hang recorded as a result), ``distributed`` (the same tasks on a Dask cluster), ``preload``
(engines imported once by the forkserver)."""
