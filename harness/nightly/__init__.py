"""The nightly comparison run: ``suites`` (which scenes, methods and settings), ``cells`` (one
task's measures on one scene and method, as cells), ``scene_cells`` (the cells a scene adds of
its own), ``run`` (the run itself: tasks to workers, cells to the history, the report)."""
