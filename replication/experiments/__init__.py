"""Experiments: each returns results (dataclasses of DataFrames) and never writes result files."""
