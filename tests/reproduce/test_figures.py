"""Reproduced seed figures (grainmech.reproduce): values against independent references."""

import math

import numpy as np
import pytest

from grainmech.errors import GrainmechError
from grainmech.reproduce import (
    FIGURES,
    build,
    fabric_sections,
    isotropic_moduli,
    linear_moduli,
    normalize_id,
    stress_paths,
)


def _eq_4_15(n, a20, a22, b22):
    """Seed Eq. 4.15 written out with the seed's angles (n_z = cos g, n_y = sin g cos b)."""
    g = np.arccos(np.clip(n[:, 2], -1, 1))
    b = np.arctan2(n[:, 0], n[:, 1])
    p2 = 0.5 * (3 * np.cos(g) ** 2 - 1)
    return 1 + a20 * p2 + 3 * np.sin(g) ** 2 * (a22 * np.cos(2 * b) + b22 * np.sin(2 * b))


def test_fig4_2_sections_match_eq_4_15():
    d = fabric_sections.fig4_2(n_angles=73)
    for name, (a20, a22, b22) in fabric_sections.FABRICS.items():
        for plane in fabric_sections.PLANES:
            n = np.column_stack([d.column(k, fabric=name, plane=plane) for k in ("n_x", "n_y", "n_z")])
            assert np.allclose(np.linalg.norm(n, axis=1), 1.0)
            assert np.allclose(d.column("density_4pi", fabric=name, plane=plane),
                               _eq_4_15(n, a20, a22, b22), atol=1e-12)
    # the plane really is the plane named
    assert np.all(d.column("n_x", fabric="monoclinic", plane="x=0") == 0)
    assert np.all(d.column("n_z", fabric="monoclinic", plane="z=0") == 0)


def test_fig4_3_poisson_is_quarter_at_smooth_contacts_and_decreasing():
    d = linear_moduli.fig4_3()
    k, E, nu = d.table["ks_kn"], d.table["E"], d.table["nu"]
    assert k[0] == 0 and nu[0] == pytest.approx(0.25, abs=1e-14)
    assert np.all(np.diff(nu) < 0)
    assert np.all(np.diff(E) > 0)
    # isotropic closed form, seed counting: (N/V) r^2 = 3 m r^2/(4 pi r^3 (1+e))
    r, m, e, kn = 0.01, 9.0, 0.57, 3800.0
    s = 3 * m / (4 * math.pi * r * (1 + e))
    assert np.allclose(nu, (1 - k) / (4 + k), atol=1e-13)
    assert np.allclose(E, s * kn * (2 + 3 * k) / (3 * (4 + k)), rtol=1e-12)


def test_fig4_4_to_4_7_structure():
    ti = linear_moduli.moduli(0.8, 0, 0, 0.5)
    assert ti["E_xx"] == pytest.approx(ti["E_yy"], rel=1e-12)
    assert ti["nu_zx"] == pytest.approx(ti["nu_zy"], rel=1e-12)
    assert ti["E_zz"] > ti["E_xx"]  # a20 > 0: more contacts along z
    orth = linear_moduli.moduli(0.2, 0.25, 0, 0.5)
    assert orth["E_yy"] > orth["E_zz"] > orth["E_xx"]
    phys = linear_moduli.moduli(0.2, 0.25, 0, 0.5, convention="physical")
    assert phys["E_zz"] == pytest.approx(2 * orth["E_zz"], rel=1e-12)
    assert phys["nu_xy"] == pytest.approx(orth["nu_xy"], rel=1e-12)
    assert linear_moduli.fig4_6().meta["gxy_identity_error"] < 1e-12
    d7 = linear_moduli.fig4_7(n=31)
    at0 = d7.table["a20"] == 0
    for key in ("E_zz_ratio", "E_xx_ratio", "nu_zx_ratio", "nu_xy_ratio"):
        assert np.allclose(d7.table[key][at0], 1.0)


def test_fig6_7_exponent_is_one_third_and_conventions_differ_by_two():
    d = isotropic_moduli.fig6_7()
    assert d.meta["exponent_seed"] == pytest.approx(1 / 3, abs=1e-6)
    assert d.meta["exponent_physical"] == pytest.approx(1 / 3, abs=1e-6)
    assert np.allclose(d.table["G_physical"], 2 * d.table["G_seed"], rtol=1e-12)
    assert np.allclose(d.table["G_physical"], d.table["G_walton_rough"], rtol=1e-10)
    assert d.meta["coordination"] == pytest.approx(3.183 ** (2.469 - 0.6), rel=1e-12)


def test_fig6_8_and_6_9_values():
    d8 = isotropic_moduli.fig6_8()
    assert np.allclose(d8.table["m_chang"], 23 - 25 * d8.table["void_ratio"])
    # Hardin-Black at e = 0.6, sigma = 20 psi, by hand: 2630 * 1.57^2 * sqrt(20) / 1.6
    assert isotropic_moduli.hardin_black(0.6, 20.0) == pytest.approx(18119.661, rel=1e-7)
    d9 = isotropic_moduli.fig6_9()
    assert d9.meta["hb_e06_s20"] == pytest.approx(18119.661, rel=1e-7)
    assert d9.meta["radius_deviation"] < 1e-12
    sel = d9.table["panel"] == "pressure"
    slope = np.polyfit(np.log(d9.table["sigma"][sel]), np.log(d9.table["G_seed"][sel]), 1)[0]
    assert slope == pytest.approx(1 / 3, abs=1e-9)
    slope_hb = np.polyfit(np.log(d9.table["sigma"][sel]), np.log(d9.table["G_hardin_black"][sel]), 1)[0]
    assert slope_hb == pytest.approx(0.5, abs=1e-12)


def test_fig6_10_state_estimate_moduli_drop_past_critical_ratio():
    rstar = stress_paths.critical_ratio()
    assert rstar == pytest.approx(2.3712, abs=1e-4)
    ratios = (1.0, 2.0, 2.25, 2.75, 3.0)
    t = stress_paths.compute(ratios, n_steps=6, extra_degree=31)
    for kind in stress_paths.PATHS:
        sel = (t["method"] == "state estimate") & (t["path"] == kind)
        slide, E, G = t["sliding"][sel], t["E_zz"][sel], t["G_xz"][sel]
        assert np.all(slide[:3] == 0) and np.all(slide[3:] > 0.1)
        assert E[3] < 0.93 * E[2] and G[3] < 0.95 * G[2]
        # below R* the requested stress is reached exactly
        assert np.allclose(t["ratio_reached"][sel][:3], ratios[:3], rtol=1e-10)
    # the seed's trends below R*: E_zz up on compression, down on reduced compression
    def ezz(kind, i):
        sel = (t["method"] == "state estimate") & (t["path"] == kind)
        return t["E_zz"][sel][i]
    assert ezz("compression", 2) > ezz("compression", 0)
    assert ezz("reduced-compression", 2) < ezz("reduced-compression", 0)
    # both methods agree at the isotropic start
    pf = (t["method"] == "path following") & (t["path"] == "compression")
    assert t["E_zz"][pf][0] == pytest.approx(ezz("compression", 0), rel=1e-10)


@pytest.mark.parametrize("text, fid", [("4.2", "4.2"), ("fig4.3", "4.3"), ("Fig6.10", "6.10"),
                                       ("fig_6_12", "6.12"), ("figure 6.7", "6.7")])
def test_normalize_id(text, fid):
    assert normalize_id(text) == fid


@pytest.mark.parametrize("bad", ["4.1", "fig9.9", "x", ""])
def test_unknown_id_is_user_error(bad):
    with pytest.raises(GrainmechError, match="unknown figure"):
        normalize_id(bad)


def test_every_registered_figure_has_caption_and_table():
    for fid in ("4.2", "4.3", "6.8"):
        d = build(fid)
        assert d.fig_id == fid and len(d.caption) > 200
        header, rows = d.rows()
        assert len(rows) > 10 and len(header) == len(rows[0])
    assert list(FIGURES)[0] == "4.2"


def test_fig6_1_6_2_rod_packings_against_lattice_closed_forms():
    from grainmech.reproduce import rods

    k = 1 / rods.ROD["psi"]  # Ks/Kn at T = 0 (seed Eq. 3.17)
    d1, d2 = rods.fig6_1(n=73), rods.fig6_2(n=73)
    assert d2.meta["nu_A_0"] == pytest.approx(0.0, abs=1e-12)        # the seed: 0 along the rows
    assert d2.meta["nu_A_45"] == pytest.approx((1 - k) / (1 + k), rel=1e-12)
    nu_a = d2.column("nu", packing="A (square)")
    assert d2.meta["nu_A_45"] == pytest.approx(nu_a.max(), rel=1e-12)  # largest at 45 deg
    nu_b = d2.column("nu", packing="B (hexagonal)")
    assert np.allclose(nu_b, (1 - k) / (3 + k), rtol=1e-10)          # isotropic
    E_a = d1.column("E", packing="A (square)")
    assert d1.meta["E_A_0"] == pytest.approx(E_a.max()) and d1.meta["E_A_45"] == pytest.approx(E_a.min())
    assert d1.meta["E_B_spread"] < 1e-10
