# The public names of fairaudit and where each is defined: read by lazy_loader.attach_stub (each module is imported
# when one of its names is first used; SPEC 1) and by type checkers. No docstring: fairaudit/__init__.py has the
# package's, which the API reference shows.

from .base.checks import choice, number_type, real, whole
from .base.errors import FairauditError, InputError, UnderflowError, optional_modules
from .base.files import write_atomic
from .base.json_values import number
from .base.labels import format_label
from .base.progress import ProgressBar, progress_bar
from .base.toml_documents import FieldProblem, distinct_labels, parse_toml, validation_error
from .certification.certificate import Certificate, certify
from .certification.curves import PrivacyCurve, privacy_curve
from .certification.spec import Spec, load_spec, parse_spec
from .data.counts import CountTable, count_file, count_records, count_table
from .data.csv_format import CsvFormat
from .data.record_files import read_records
from .filter.filters import PrivacyFilter
from .laws.closed_forms import (
    epsilon_from_keep_probability,
    keep_probability,
    randomized_response,
    split_by_keep,
)
from .laws.composition import compose
from .laws.families import MechanismFamily, epsilon_scale, product_family, randomized_response_family
from .laws.mechanisms import Mechanism, from_matrix, identity, product
from .laws.tables import Kernel, Law, Population
from .laws.utilities import Utility, UtilityClass, from_function, from_table, indicator
from .metrics.assumptions import Assumption
from .metrics.bounds import (
    Bound,
    corollary_bound,
    main_theorem,
    main_theorem_tight,
    paper_bound,
    tight_bound,
)
from .metrics.fairness import Fairness, global_fairness, local_fairness
from .metrics.parity import demographic_parity, equalized_odds
from .metrics.reductions import expected_utility
from .metrics.sup_fairness import sup_global_fairness, sup_local_fairness
from .metrics.utility_range import UtilityRange, fairness_range
from .reports.figures import mark_infinite
from .reports.plots import plot_curve, save_figure
from .statistics.intervals import FairnessIntervals, Interval, IntervalOptions, fairness_intervals
from .statistics.ll144 import FourFifths, ImpactRatios, impact_ratios
from .statistics.missing_demographics import MissingDataBounds, aclu_bounds, missing_data_bounds
from .statistics.published_audit import PublishedAudit, check_published
from .statistics.record_audit import Audit, audit, utility_from_expression
from .statistics.record_options import RecordOptions
from .statistics.sample_size import SamplePlan, plan
from .verification.rederive import Verification, verify
from .worstcase.black_box import black_box_bound
from .worstcase.black_box_result import BlackBoxCertificate
from .worstcase.calibration import calibrate, calibrate_randomized_response
from .worstcase.calibration_result import Calibration
from .worstcase.known_law import WorstUtility, worst_utility
from .worstcase.known_utility import worst_model
from .worstcase.worst_cases import WorstCase, WorstModel

__version__: str

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
    "epsilon_scale",
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
