"""Statistics: finite-sample intervals of every metric (:mod:`~fairaudit.statistics.intervals`), sample-size
plans, small cells, audits of decision records (:mod:`~fairaudit.statistics.record_audit`) and NYC Local Law
144 impact ratios (:mod:`~fairaudit.statistics.ll144`). Imports base, laws, metrics and data.
"""
