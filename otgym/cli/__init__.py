"""Command-line interface (top layer): ``otgym demo|plan|chip ...``."""
