"""Where runs happen: ``simulate`` (validate, then step a method; an engine mode in a worker
process, where it may abort or hang), ``isolation`` (one call in a fresh forkserver worker, a
crash or hang recorded as a result), ``pool`` (workers reused call after call, results sent ahead
of a crash), ``distributed`` (the nightly's tasks on a Dask cluster), ``environment`` (the package
versions and code digest a run records and a Dask worker must share), ``preload`` (engines
imported once by the forkserver)."""
