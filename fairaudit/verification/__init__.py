"""Certificates checked by a third party: every certified number re-derived from what the certificate records.

:func:`~fairaudit.verification.rederive.verify` reads a certificate's JSON (its format is the JSON Schema
``certificate.schema.json`` shipped here, checked by :mod:`~fairaudit.verification.schema`) and re-derives its
numbers from its ``inputs`` in exact rational arithmetic with directed rounding (ln and exp enclosed by python-flint's
``arb`` balls, :mod:`~fairaudit.verification.enclosures`), importing neither cvxpy, Clarabel nor scipy. It imports
nothing else of fairaudit, so that a third party reads one package (``tests/verification/test_init_independent.py``),
and it solves nothing: the black box over the model's table and the worst case over the class Lipschitz in the group
are bounded from the proofs the certificate records, by weak duality in exact arithmetic, and their witnesses
checked (issue 80). Guide: ``docs/certificates.md`` ("Checking a certificate").
"""
