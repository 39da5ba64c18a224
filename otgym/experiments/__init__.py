"""Experiments: end-to-end jobs that produce files (figures, tables, CSV) for people, one
package per study (``otgym/experiments/<study>/``): its ``config`` (what it runs, checked
before any work), ``run`` (the work) and ``report`` (tables, figures, markdown) where a
study has them apart; ``common`` holds what every study shares (the seed protocol, the
output folder check, progress lines, the paper's numbers). The CLI (``otgym.cli``)
parses, checks and calls them."""
