"""Specs and certificates: the TOML spec (:mod:`~fairaudit.certification.spec`), the certificate of a spec
(:mod:`~fairaudit.certification.certificate`), its worst case and its fairness-privacy curve. Imports every
layer below it.
"""
