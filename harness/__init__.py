"""The harness: runs methods on scenes, measures, stores history, and the ``harness`` CLI."""
