"""Laws and mechanisms: probability tables indexed [x, a, u] (:mod:`~fairaudit.laws.tables`), privacy
mechanisms on the sensitive attribute and the context (:mod:`~fairaudit.laws.mechanisms`) and utilities
(:mod:`~fairaudit.laws.utilities`, :mod:`~fairaudit.laws.utility_expression`). Imports :mod:`fairaudit.base`.
"""
