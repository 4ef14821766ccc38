"""Data and counting: decision records (DataFrames, files read by DuckDB, Spark) counted into tables of
counts and empirical laws (:mod:`~fairaudit.data.counts`). Imports base and laws.
"""
