"""Testing helpers for fairaudit: hypothesis strategies (needs the ``hypothesis`` package).

``import fairaudit`` never imports this package; import it in tests::

    from fairaudit.testing import laws, mechanisms, utilities

See :mod:`fairaudit.testing.strategies` (populations, kernels, laws, utilities)
and :mod:`fairaudit.testing.mechanism_strategies` (mechanisms) for what each
strategy draws and guarantees.
"""

from .mechanism_strategies import mechanisms, product_mechanisms, randomized_responses
from .strategies import kernels, laws, populations, utilities

__all__ = [
    "kernels",
    "laws",
    "mechanisms",
    "populations",
    "product_mechanisms",
    "randomized_responses",
    "utilities",
]
