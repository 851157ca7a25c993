"""Command implementations behind ``harness`` (one module per command group)."""
