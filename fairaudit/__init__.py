"""fairaudit: certified fairness auditing.

Exact utility-aware fairness metrics (local and global g-fairness) of decision
systems, upper bounds on unfairness that hold for any decision model behind a
privacy filter on the sensitive attribute, and calibration of the privacy
budget ε that meets a fairness target.

Arrays are indexed [x, a, u] (context, sensitive group, decision); log ratios
are in nats. See docs/ for the guide and proofs/ for the proofs.
"""

from ._errors import FairauditError, InputError
from .audit import Audit, audit, utility_from_expression
from .bounds import Assumption, Bound, corollary_bound, main_theorem, main_theorem_tight, paper_bound, tight_bound
from .calibrate import Calibration, calibrate_randomized_response
from .certify import Certificate, certify
from .curves import PrivacyCurve, privacy_curve
from .estimate import CountTable, count_file, count_records, count_table, read_records
from .intervals import FairnessIntervals, Interval, fairness_intervals
from .laws import Kernel, Law, Population, compose
from .metrics import (
    demographic_parity,
    equalized_odds,
    expected_utility,
    global_fairness,
    local_fairness,
    sup_global_fairness,
    sup_local_fairness,
)
from .plan import SamplePlan, plan
from .privacy import (
    Mechanism,
    MechanismFamily,
    from_matrix,
    identity,
    product,
    product_family,
    randomized_response,
    randomized_response_family,
)
from .spec import Spec, load_spec, parse_spec
from .utility import Utility, from_function, from_table, indicator
from .worstcase import (
    BlackBoxCertificate,
    WorstCase,
    WorstModel,
    WorstUtility,
    black_box_bound,
    worst_model,
    worst_utility,
)

__version__ = "0.1.0"

__all__ = [
    # errors
    "FairauditError",
    "InputError",
    # laws, mechanisms and utilities
    "Kernel",
    "Law",
    "Mechanism",
    "MechanismFamily",
    "Population",
    "Utility",
    "compose",
    "from_function",
    "from_matrix",
    "from_table",
    "identity",
    "indicator",
    "product",
    "product_family",
    "randomized_response",
    "randomized_response_family",
    # exact metrics
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
    "FairnessIntervals",
    "Interval",
    "SamplePlan",
    "audit",
    "count_file",
    "count_records",
    "count_table",
    "fairness_intervals",
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
    # calibration
    "Calibration",
    "calibrate_randomized_response",
]
