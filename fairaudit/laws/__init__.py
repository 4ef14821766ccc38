"""Laws and mechanisms: probability tables indexed [x, a, u] (:mod:`~fairaudit.laws.tables`), privacy
mechanisms on the sensitive attribute and the context (:mod:`~fairaudit.laws.mechanisms`; k-ary randomized response in
closed form, :mod:`~fairaudit.laws.closed_forms`; families ε ↦ M_ε, :mod:`~fairaudit.laws.families`) and utilities
(:mod:`~fairaudit.laws.utilities`, :mod:`~fairaudit.laws.utility_expression`). Imports :mod:`fairaudit.base`.
"""
