"""Reports: stored results -> markdown tables and charts. Never simulates."""
