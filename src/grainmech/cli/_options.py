"""Command-line options shared by several sub-commands (private)."""

from __future__ import annotations

import argparse


def add_cluster_options(p: argparse.ArgumentParser) -> None:
    """``--workers N | --scheduler ADDRESS``: where the Dask tasks of a command run (mutually exclusive)."""
    g = p.add_mutually_exclusive_group()
    g.add_argument("--workers", type=int, metavar="N",
                   help="N local workers (N > 1: worker processes); default: one in-process worker")
    g.add_argument("--scheduler", metavar="ADDRESS",
                   help="address of a running dask scheduler, e.g. tcp://10.0.0.5:8786")
