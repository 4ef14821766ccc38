"""Certificates checked by a third party: every certified number re-derived from what the certificate records.

:func:`~fairaudit.verification.rederive.verify` reads a certificate's JSON (its format is the JSON Schema
``certificate.schema.json`` shipped here, checked by :mod:`~fairaudit.verification.schema`) and re-derives its
numbers from its ``inputs`` in exact rational arithmetic with directed rounding (ln and exp enclosed by python-flint's
``arb`` balls, :mod:`~fairaudit.verification.enclosures`), importing neither cvxpy, Clarabel nor scipy. It imports
nothing else of fairaudit, so that a third party reads one package (``tests/verification/test_init_independent.py``),
but for now :mod:`fairaudit.base.exact_programs`, the small exact solves of ``class_check`` (the Lipschitz class),
until certify records their proofs too: the black box over the model's table is bounded from the recorded proofs,
nothing solved (issue 80). Guide: ``docs/certificates.md`` ("Checking a certificate").
"""
