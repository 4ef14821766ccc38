"""fairaudit: certified fairness auditing.

Exact utility-aware fairness metrics (local and global g-fairness) of decision
systems, upper bounds on unfairness that hold for any decision model behind a
privacy filter on the sensitive attribute, and calibration of the privacy
budget ε that meets a fairness target.

Arrays are indexed [x, a, u] (context, sensitive group, decision); log ratios
are in nats. See docs/ for the guide and proofs/ for the proofs.
"""

from __future__ import annotations

from fairaudit.base.checks import choice, number_type, real, whole
from fairaudit.base.errors import FairauditError, InputError, UnderflowError, optional_modules
from fairaudit.base.files import write_atomic
from fairaudit.base.json_values import number
from fairaudit.base.labels import format_label
from fairaudit.base.progress import ProgressBar, progress_bar
from fairaudit.base.toml_documents import FieldProblem, distinct_labels, parse_toml, validation_error
from fairaudit.certification.certificate import Certificate, certify
from fairaudit.certification.curves import PrivacyCurve, privacy_curve
from fairaudit.certification.spec import Spec, load_spec, parse_spec
from fairaudit.data.counts import CountTable, count_file, count_records, count_table
from fairaudit.data.csv_format import CsvFormat
from fairaudit.data.record_files import read_records
from fairaudit.filter.filters import PrivacyFilter
from fairaudit.laws.closed_forms import (
    epsilon_from_keep_probability,
    keep_probability,
    randomized_response,
    split_by_keep,
)
from fairaudit.laws.composition import compose
from fairaudit.laws.families import MechanismFamily, product_family, randomized_response_family
from fairaudit.laws.mechanisms import Mechanism, from_matrix, identity, product
from fairaudit.laws.tables import Kernel, Law, Population
from fairaudit.laws.utilities import Utility, UtilityClass, from_function, from_table, indicator
from fairaudit.metrics.assumptions import Assumption
from fairaudit.metrics.bounds import (
    Bound,
    corollary_bound,
    main_theorem,
    main_theorem_tight,
    paper_bound,
    tight_bound,
)
from fairaudit.metrics.fairness import Fairness, global_fairness, local_fairness
from fairaudit.metrics.parity import demographic_parity, equalized_odds
from fairaudit.metrics.reductions import expected_utility
from fairaudit.metrics.sup_fairness import sup_global_fairness, sup_local_fairness
from fairaudit.metrics.utility_range import UtilityRange, fairness_range
from fairaudit.reports.figures import mark_infinite
from fairaudit.reports.plots import plot_curve, save_figure
from fairaudit.statistics.intervals import FairnessIntervals, Interval, IntervalOptions, fairness_intervals
from fairaudit.statistics.ll144 import FourFifths, ImpactRatios, impact_ratios
from fairaudit.statistics.missing_demographics import MissingDataBounds, aclu_bounds, missing_data_bounds
from fairaudit.statistics.published_audit import PublishedAudit, check_published
from fairaudit.statistics.record_audit import Audit, audit, utility_from_expression
from fairaudit.statistics.record_options import RecordOptions
from fairaudit.statistics.sample_size import SamplePlan, plan
from fairaudit.verification.rederive import Verification, verify
from fairaudit.worstcase.black_box import black_box_bound
from fairaudit.worstcase.black_box_result import BlackBoxCertificate
from fairaudit.worstcase.calibration import calibrate, calibrate_randomized_response
from fairaudit.worstcase.calibration_result import Calibration
from fairaudit.worstcase.known_law import WorstUtility, worst_utility
from fairaudit.worstcase.known_utility import worst_model
from fairaudit.worstcase.worst_cases import WorstCase, WorstModel

__version__ = "0.1.0"

__all__ = [
    # errors
    "FairauditError",
    "InputError",
    "UnderflowError",
    # laws, mechanisms and utilities
    "Kernel",
    "Law",
    "Mechanism",
    "MechanismFamily",
    "Population",
    "Utility",
    "UtilityClass",
    "compose",
    "epsilon_from_keep_probability",
    "from_function",
    "from_matrix",
    "from_table",
    "identity",
    "indicator",
    "keep_probability",
    "product",
    "product_family",
    "randomized_response",
    "randomized_response_family",
    "split_by_keep",
    # exact metrics
    "Fairness",
    "demographic_parity",
    "equalized_odds",
    "expected_utility",
    "global_fairness",
    "local_fairness",
    "sup_global_fairness",
    "sup_local_fairness",
    # records, audits and intervals
    "Audit",
    "CountTable",
    "CsvFormat",
    "FairnessIntervals",
    "FourFifths",
    "ImpactRatios",
    "Interval",
    "IntervalOptions",
    "MissingDataBounds",
    "PublishedAudit",
    "RecordOptions",
    "SamplePlan",
    "UtilityRange",
    "aclu_bounds",
    "audit",
    "check_published",
    "count_file",
    "count_records",
    "count_table",
    "fairness_intervals",
    "fairness_range",
    "impact_ratios",
    "missing_data_bounds",
    "plan",
    "read_records",
    "utility_from_expression",
    # bounds and certificates
    "Assumption",
    "BlackBoxCertificate",
    "Bound",
    "Certificate",
    "PrivacyCurve",
    "Spec",
    "WorstCase",
    "WorstModel",
    "WorstUtility",
    "black_box_bound",
    "certify",
    "corollary_bound",
    "load_spec",
    "main_theorem",
    "main_theorem_tight",
    "paper_bound",
    "parse_spec",
    "privacy_curve",
    "tight_bound",
    "worst_model",
    "worst_utility",
    # the privacy filter you deploy
    "PrivacyFilter",
    # certificates checked by a third party
    "Verification",
    "verify",
    # calibration
    "Calibration",
    "calibrate",
    "calibrate_randomized_response",
    # figures
    "mark_infinite",
    "plot_curve",
    "save_figure",
    # what the core shares with plug-ins (fairaudit.experiments): argument checks, TOML tables, labels and numbers
    # as reports show them, atomic writes, progress bars, optional modules
    "FieldProblem",
    "ProgressBar",
    "choice",
    "distinct_labels",
    "format_label",
    "number",
    "number_type",
    "optional_modules",
    "parse_toml",
    "progress_bar",
    "real",
    "validation_error",
    "whole",
    "write_atomic",
]
