"""Engine adapters: one module per engine; ``ENGINE_METHODS[id]`` is an engine mode."""
from __future__ import annotations

ENGINE_METHODS: dict[str, object] = {}
