"""fairaudit: certified fairness auditing.

Exact utility-aware fairness metrics (local and global g-fairness) of decision
systems, upper bounds on unfairness that hold for any decision model behind a
privacy filter on the sensitive attribute, and calibration of the privacy
budget ε that meets a fairness target.

Arrays are indexed [x, a, u] (context, sensitive group, decision); log ratios
are in nats. See docs/ for the guide and proofs/ for the proofs.
"""

from __future__ import annotations

import importlib
import sys
import types
from typing import TYPE_CHECKING, Any

from ._errors import FairauditError, InputError

if TYPE_CHECKING:  # what type checkers see; at run time each name is imported when first used (_SOURCES)
    from ._arrays import format_label
    from ._figure import mark_infinite
    from ._io import write_atomic
    from ._json import number
    from ._toml import FieldProblem, distinct_labels, parse_toml, validation_error
    from ._validation import choice, number_type, real, whole
    from .audit import Audit, audit, utility_from_expression
    from .bounds import Assumption, Bound, corollary_bound, main_theorem, main_theorem_tight, paper_bound, tight_bound
    from .calibrate import Calibration, calibrate, calibrate_randomized_response
    from .certify import Certificate, certify
    from .curves import PrivacyCurve, privacy_curve
    from .estimate import CountTable, CsvFormat, count_file, count_records, count_table, read_records
    from .impact_ratio import ImpactRatios, impact_ratios
    from .intervals import FairnessIntervals, Interval, fairness_intervals
    from .laws import Kernel, Law, Population, compose
    from .metrics import (
        Fairness,
        demographic_parity,
        equalized_odds,
        expected_utility,
        global_fairness,
        local_fairness,
        sup_global_fairness,
        sup_local_fairness,
    )
    from .plan import SamplePlan, plan
    from .plot import plot_curve, save_figure
    from .privacy import (
        Mechanism,
        MechanismFamily,
        epsilon_from_keep_probability,
        from_matrix,
        identity,
        keep_probability,
        product,
        product_family,
        randomized_response,
        randomized_response_family,
        split_by_keep,
    )
    from .spec import Spec, load_spec, parse_spec
    from .utility import Utility, from_function, from_table, indicator
    from .utility_range import UtilityRange, fairness_range
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
    "ImpactRatios",
    "Interval",
    "SamplePlan",
    "UtilityRange",
    "audit",
    "count_file",
    "count_records",
    "count_table",
    "fairness_intervals",
    "fairness_range",
    "impact_ratios",
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
    "calibrate",
    "calibrate_randomized_response",
    # figures
    "mark_infinite",
    "plot_curve",
    "save_figure",
    # what the core shares with plug-ins (fairaudit.experiments): argument checks, TOML tables, labels and numbers
    # as reports show them, atomic writes
    "FieldProblem",
    "choice",
    "distinct_labels",
    "format_label",
    "number",
    "number_type",
    "parse_toml",
    "real",
    "validation_error",
    "whole",
    "write_atomic",
]


# The public names by the module that defines them: ``import fairaudit`` imports none of these modules (nor
# numpy, pandas, scipy or cvxpy); the first use of a name imports its module (PEP 562). A test checks that this
# table and the TYPE_CHECKING imports above list the same names.
_SOURCES: dict[str, tuple[str, ...]] = {
    "_arrays": ("format_label",),
    "_figure": ("mark_infinite",),
    "_io": ("write_atomic",),
    "_json": ("number",),
    "_toml": ("FieldProblem", "distinct_labels", "parse_toml", "validation_error"),
    "_validation": ("choice", "number_type", "real", "whole"),
    "audit": ("Audit", "audit", "utility_from_expression"),
    "bounds": (
        "Assumption",
        "Bound",
        "corollary_bound",
        "main_theorem",
        "main_theorem_tight",
        "paper_bound",
        "tight_bound",
    ),
    "calibrate": ("Calibration", "calibrate", "calibrate_randomized_response"),
    "certify": ("Certificate", "certify"),
    "curves": ("PrivacyCurve", "privacy_curve"),
    "estimate": ("CountTable", "CsvFormat", "count_file", "count_records", "count_table", "read_records"),
    "impact_ratio": ("ImpactRatios", "impact_ratios"),
    "intervals": ("FairnessIntervals", "Interval", "fairness_intervals"),
    "laws": ("Kernel", "Law", "Population", "compose"),
    "metrics": (
        "Fairness",
        "demographic_parity",
        "equalized_odds",
        "expected_utility",
        "global_fairness",
        "local_fairness",
        "sup_global_fairness",
        "sup_local_fairness",
    ),
    "plan": ("SamplePlan", "plan"),
    "plot": ("plot_curve", "save_figure"),
    "privacy": (
        "Mechanism",
        "MechanismFamily",
        "epsilon_from_keep_probability",
        "from_matrix",
        "identity",
        "keep_probability",
        "product",
        "product_family",
        "randomized_response",
        "randomized_response_family",
        "split_by_keep",
    ),
    "spec": ("Spec", "load_spec", "parse_spec"),
    "utility": ("Utility", "from_function", "from_table", "indicator"),
    "utility_range": ("UtilityRange", "fairness_range"),
    "worstcase": (
        "BlackBoxCertificate",
        "WorstCase",
        "WorstModel",
        "WorstUtility",
        "black_box_bound",
        "worst_model",
        "worst_utility",
    ),
}
_MODULE_OF = {name: module for module, names in _SOURCES.items() for name in names}


def __getattr__(name: str) -> Any:
    """A public name, imported from its module on first use (then cached in the package's namespace)."""
    module = _MODULE_OF.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{module}", __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_MODULE_OF))


class _Package(types.ModuleType):
    """The package's module type: ``fairaudit.audit`` stays the function when the module ``fairaudit.audit`` loads.

    Importing a submodule binds it as an attribute of its package. Four submodules share their name with the
    function they define (``audit``, ``calibrate``, ``certify``, ``plan``); the function is what ``fairaudit.audit``
    has always been, whichever is imported first.
    """

    def __setattr__(self, name: str, value: Any) -> None:
        if isinstance(value, types.ModuleType) and name in _MODULE_OF and _MODULE_OF[name] == name:
            value = getattr(value, name)
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package
