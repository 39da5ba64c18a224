"""Experiments: end-to-end jobs that produce files (figures, tables, CSV) for people."""
