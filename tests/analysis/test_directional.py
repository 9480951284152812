"""Seed Eq. 6.1-6.2 (corrected) against tensors.directional_young / directional_poisson."""

import numpy as np
import pytest

from grainmech.analysis import apparent_moduli
from grainmech.elasticity import (
    directional_poisson,
    directional_young,
    isotropic_stiffness,
    transversely_isotropic_stiffness,
)
from grainmech.errors import ParameterError


def test_isotropic_constant_in_every_direction():
    E, nu = apparent_moduli(isotropic_stiffness(E=2e8, nu=0.2), np.linspace(0, np.pi, 7))
    assert np.allclose(E, 2e8) and np.allclose(nu, 0.2)


def test_transversely_isotropic_against_directional_functions():
    C = transversely_isotropic_stiffness(E_p=1e8, nu_p=0.2, E_a=2e8, nu_ap=0.15, G_a=5e7)
    al = np.linspace(0, np.pi / 2, 5)
    E, nu = apparent_moduli(C, al, plane="xz")
    d = np.stack([np.cos(al), np.zeros_like(al), np.sin(al)], axis=1)
    m = np.stack([-np.sin(al), np.zeros_like(al), np.cos(al)], axis=1)
    assert np.allclose(E, directional_young(C, d), rtol=1e-10)
    assert np.allclose(nu, [directional_poisson(C, d[i], m[i]) for i in range(len(al))], rtol=1e-10)
    assert E[0] == pytest.approx(1e8) and E[-1] == pytest.approx(2e8)
    assert nu[-1] == pytest.approx(0.15)  # load along z (axis), lateral x: nu_ap


def test_plane_error():
    with pytest.raises(ParameterError, match="plane"):
        apparent_moduli(isotropic_stiffness(E=1.0, nu=0.2), [0.0], plane="xx")
