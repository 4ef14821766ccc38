"""Certificates checked by a third party: every certified number re-derived from what the certificate records.

:func:`~fairaudit.verification.rederive.verify` reads a certificate's JSON (its format is the JSON Schema
``certificate.schema.json`` shipped here, checked by :mod:`~fairaudit.verification.schema`) and re-derives its
numbers from its ``inputs`` in exact rational arithmetic with directed rounding (:mod:`fairaudit.base.outward`),
importing neither cvxpy, Clarabel nor scipy. Imports :mod:`fairaudit.filter` (a filter's exact ε) and
:mod:`fairaudit.base`. Guide: ``docs/certificates.md`` ("Checking a certificate").
"""
