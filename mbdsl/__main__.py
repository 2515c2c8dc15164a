"""``python -m mbdsl`` runs the command line."""

from .cli.main import run

run()
