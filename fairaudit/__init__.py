"""fairaudit: certified fairness auditing.

Exact utility-aware fairness metrics (local and global g-fairness) of decision
systems, upper bounds on unfairness that hold for any decision model behind a
privacy filter on the sensitive attribute, and calibration of the privacy
budget ε that meets a fairness target.

Arrays are indexed [x, a, u] (context, sensitive group, decision); log ratios
are in nats. See docs/ for the guide and proofs/ for the proofs.
"""

import lazy_loader

__version__ = "0.1.0"

# The public names are listed once, in __init__.pyi, with the module each comes from; each module is imported when one
# of its names is first used (SPEC 1), so that ``import fairaudit``, ``fairaudit --help`` and ``--version`` stay light.
__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)
