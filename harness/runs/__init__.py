"""Runs: sweep expansion, executors (serial, process pool, Ray), run directories, the result
store."""
