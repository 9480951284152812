"""Shared fixtures: every test runs in its own empty working directory (commands that
write to their default output folder, ``./grainmech-out/<command>``, write there), and
``cli`` runs the command line in-process."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import pytest


@pytest.fixture(autouse=True)
def _in_tmp_dir(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)


@dataclass
class CliRun:
    """Exit status and captured output of one ``grainmech`` invocation."""

    rc: int
    out: str
    err: str


@pytest.fixture
def cli(capsys) -> Callable[..., CliRun]:
    """``cli("run", "-o", out)`` -> :class:`CliRun` (``grainmech.cli.main`` in-process).

    Arguments may be paths or numbers (converted with ``str``); ``--help`` and argparse's
    usage errors give their exit status instead of raising ``SystemExit``.
    """
    from grainmech.cli import main

    def run(*args: object) -> CliRun:
        capsys.readouterr()
        try:
            rc = main([str(a) for a in args])
        except SystemExit as exc:  # argparse's --help and usage errors
            rc = 0 if exc.code is None else exc.code if isinstance(exc.code, int) else 1
        cap = capsys.readouterr()
        return CliRun(rc, cap.out, cap.err)

    return run


#: the small cyclic run of the command-line tests (tests/cli/test_run_command.py, tests/io/test_browser.py)
CYCLIC = """
[microstructure]
void_ratio = 0.65
coordination = "chang"
radius = "0.25 mm"
[contacts]
law = "mindlin-deresiewicz"
shear_modulus = "44 GPa"
poisson = 0.08
friction = 0.5
[initial]
pressure = "100 kPa"
[test]
kind = "cyclic-simple-shear"
amplitudes = [1e-6, 1e-4, 1e-3]
n_cycles = 2
steps_per_cycle = 16
[quadrature]
degree = 11
"""


#: a cyclic run on the shipped 'dense' packing (fill law, extra_contacts, method, model, amps, constant)
DENSE_CYCLIC = """
[contacts]
law = "{law}"
shear_modulus = "29 GPa"
poisson = 0.15
friction = 0.5
{extra_contacts}
[initial]
pressure = "100 kPa"
[model]
method = {method}
packing = "dense"
{model}
[test]
kind = "cyclic-simple-shear"
amplitudes = {amps}
n_cycles = 2
steps_per_cycle = 16
constant = "{constant}"
"""


def write_fcc_packing(d):
    """A 103-grain disordered fcc packing of 0.25 mm quartz-like spheres (G 29 GPa, nu 0.15,
    Mindlin-Deresiewicz, friction 0.5) in equilibrium (frictionless preparation), written as
    grainmech NPZ network files ``contacts.npz``, ``particles.npz`` in folder ``d``; returns the network."""
    import numpy as np

    from grainmech.contact import MindlinDeresiewicz
    from grainmech.driver.packing import equilibrate_network, perturbed_fcc_network

    law = MindlinDeresiewicz(29e9, 0.15, 2.5e-4, friction=0.5)
    net = equilibrate_network(perturbed_fcc_network(3, radius=2.5e-4, seed=1, vacancies=0.05, overlap=0.002,
                                                    disorder=0.0004), law)
    pos, f = net.positions, net.force
    np.savez(d / "particles.npz", id=net.ids, x=pos[:, 0], y=pos[:, 1], z=pos[:, 2], radius=net.radii,
             cell=net.box.cell, origin=net.box.origin)
    np.savez(d / "contacts.npz", id1=net.ids[net.i], id2=net.ids[net.j], fx=f[:, 0], fy=f[:, 1], fz=f[:, 2],
             delta=net.overlap)
    return net


def default_run_affine(text: str | None = None) -> str:
    """The smooth-quartz run config ``tests/data/smooth_quartz_run.toml`` (or ``text``) with
    the affine model alone.

    That config was the built-in default before it modelled a sand; the reference numbers
    of the tests of the run's output files, checks and folder rules were worked out for it
    (void ratio 0.57, G 44 GPa, seven amplitudes). The affine model alone takes seconds.
    """
    from pathlib import Path

    if text is None:
        text = (Path(__file__).resolve().parent / "data" / "smooth_quartz_run.toml").read_text()
    head, rest = text.split("[model]", 1)
    tail = rest[rest.index("\n["):]
    return head + '[model]\nmethod = "affine"\n' + tail
