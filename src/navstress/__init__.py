"""navstress: stress-test robot navigation software in generated virtual worlds."""

__version__ = "0.1.0"
