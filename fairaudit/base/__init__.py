"""Foundations every layer uses: errors, argument checks, labels, float arrays, pairs of rows,
linear-fractional programs, TOML models, report values and atomic file writes. Imports no other layer.
"""
