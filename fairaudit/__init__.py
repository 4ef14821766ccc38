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
    "Assumption",
    "Audit",
    "BlackBoxCertificate",
    "Bound",
    "Calibration",
    "Certificate",
    "CountTable",
    "FairauditError",
    "InputError",
    "Kernel",
    "Law",
    "Mechanism",
    "MechanismFamily",
    "Population",
    "PrivacyCurve",
    "Spec",
    "Utility",
    "audit",
    "black_box_bound",
    "calibrate_randomized_response",
    "certify",
    "compose",
    "corollary_bound",
    "count_file",
    "count_records",
    "count_table",
    "demographic_parity",
    "equalized_odds",
    "expected_utility",
    "from_function",
    "fairness_intervals",
    "FairnessIntervals",
    "Interval",
    "from_matrix",
    "from_table",
    "global_fairness",
    "identity",
    "indicator",
    "load_spec",
    "local_fairness",
    "main_theorem",
    "main_theorem_tight",
    "paper_bound",
    "parse_spec",
    "product",
    "product_family",
    "randomized_response",
    "randomized_response_family",
    "read_records",
    "sup_global_fairness",
    "sup_local_fairness",
    "tight_bound",
    "utility_from_expression",
    "WorstCase",
    "WorstModel",
    "WorstUtility",
    "privacy_curve",
    "worst_model",
    "worst_utility",
    "SamplePlan",
    "plan",
]
