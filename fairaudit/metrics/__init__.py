"""Metrics and bounds: the exact local and global g-fairness of a law (:mod:`~fairaudit.metrics.fairness`), its
total-variation gaps (:mod:`~fairaudit.metrics.parity`), the sups over g (:mod:`~fairaudit.metrics.sup_fairness`),
its utility gaps, its range over an unknown utility, and the theorem bounds (:mod:`~fairaudit.metrics.bounds`).
Imports the layers below: base, laws.
"""
