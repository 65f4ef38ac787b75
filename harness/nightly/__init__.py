"""The nightly comparison run: ``suites`` (which scenes, methods and settings), ``cells`` (one
task's measures on one scene and method, as cells), ``scene_cells`` (the cells a scene adds of
its own), ``cell_kit`` (what both build their cells with; the imports run cells -> scene_cells
-> cell_kit), ``run`` (the run itself: tasks to workers, cells to the history, the report)."""
