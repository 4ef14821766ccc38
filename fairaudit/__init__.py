"""fairaudit: certified fairness auditing."""
__version__ = "0.1.0"
