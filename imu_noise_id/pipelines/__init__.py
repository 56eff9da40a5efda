"""Pipelines chaining core pieces: offline analysis of arrays, online streaming estimation."""
