"""``usv params``: the parameter table, as a list or as Markdown documentation."""

from __future__ import annotations

import argparse

from companion.param_table import all_param_defs
from companion.params import ParamStore

HELP = "show every parameter with its default, range, unit and description"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--markdown", action="store_true", help="print the table as Markdown")


def run(args: argparse.Namespace) -> int:
    store = ParamStore(all_param_defs())
    if args.markdown:
        print(store.markdown(), end="")
        return 0
    for name in store.names():
        d = store.definition(name)
        print(f"{name:<16} {store.get(name):>12g}  {d.range_text():<24} {d.description}")
    return 0
