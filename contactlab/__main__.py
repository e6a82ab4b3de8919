"""``python -m contactlab`` runs the CLI."""

from contactlab.cli import main

main(prog_name="contactlab")
