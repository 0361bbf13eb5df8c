"""``pbs batch``: many images from one job file, on warm GL contexts (docs/batch.md).

- ``app.batch.jobs``: the job file (an orbit, a sweep of one scene key, or a list of
  scene files) read and validated into a list of ``Job``s, each naming one output PNG.
- ``app.batch.worker``: renders one job in a process that keeps its GL context and its
  ``Renderer`` between jobs (a camera or key change goes through ``Renderer.update``).
- ``app.batch.run``: runs the jobs in-process, on spawned worker processes, or on Dask
  workers; resume, progress and ``manifest.jsonl``.
"""
