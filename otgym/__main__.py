"""``python -m otgym`` runs the command-line interface, as the ``otgym`` script does."""

from otgym.cli.app import main

main()
