"""Subcommands of the ``usv`` command line (see :mod:`companion.cli`)."""
