"""The nightly comparison run: ``suites`` (which scenes, methods and settings), ``cells`` (one
task's measures on one scene and method, as cells, and the loop that measures every registered
measure), ``measures`` (the built-in measures beyond a task's own, a module each), ``cell_kit``
(what both build their cells with; the imports run cells -> measures -> cell_kit), ``run`` (the
run itself: tasks to workers, cells to the history, the report)."""
