"""Testing helpers for fairaudit: hypothesis strategies (needs the ``hypothesis`` package).

``import fairaudit`` never imports this package; import it in tests::

    from fairaudit.testing import laws, mechanisms, utilities

See :mod:`fairaudit.testing.strategies` for what each strategy draws and
guarantees.
"""

from .strategies import (
    kernels,
    laws,
    mechanisms,
    populations,
    product_mechanisms,
    randomized_responses,
    utilities,
)

__all__ = [
    "kernels",
    "laws",
    "mechanisms",
    "populations",
    "product_mechanisms",
    "randomized_responses",
    "utilities",
]
