"""The privacy filter you deploy: a certified finite mechanism applied to real values, exactly.

:class:`~fairaudit.filter.filters.PrivacyFilter` holds every row of its
mechanism as integer numerators over one integer denominator
(:mod:`~fairaudit.filter.rationals`), states its own ε rounded up, and
releases values by exact integer sampling from a cryptographically secure
source of random bytes (:mod:`~fairaudit.filter.exact_sampling`; Mironov 2012).
Imports :mod:`fairaudit.laws` and :mod:`fairaudit.base`. Guide: ``docs/filter.md``.
"""
