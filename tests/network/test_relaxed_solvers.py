"""The relaxed-stiffness solvers: the compiled matrix-free CG against the NumPy reference,
and the solver names accepted by the API and by the config file.

The system is ``H q = -B`` (Lemaitre & Maloney 2006, Eq. 12); the reference for ``H`` is
the assembled sparse ``G^T K G``, for the tensor the SuperLU factorisation."""

from __future__ import annotations

import numpy as np
import pytest

from grainmech.network import contact_stiffnesses, random_network, relaxed_stiffness
from grainmech.network import relaxed as rel

G, NU = 29e9, 0.15


def _system(n=150, seed=4):
    net = random_network(n, seed=seed)
    kn, ks, _ = contact_stiffnesses(net, shear_modulus=G, poisson=NU)
    ci, cj, nrm = net.i, net.j, net.normals
    rA = net.radii[ci][:, None] * nrm
    rB = -net.radii[cj][:, None] * nrm
    s = rel._assemble(net.n_particles, ci, cj, nrm, net.branch, kn, ks, rA, rB, rotations=True)
    return net, kn, ks, nrm, rA, rB, s


def test_matrix_free_product_equals_the_assembled_hessian():
    kernel = pytest.importorskip("grainmech.network._cg_kernel")
    net, kn, ks, nrm, rA, rB, s = _system()
    x = np.random.default_rng(0).normal(size=(s.P, 6, 6))
    out = np.empty_like(x)
    xHx = np.empty(6)
    kernel.hessian_product(s.ci, s.cj, nrm, kn, ks, rA, rB, x, out, xHx)
    ref = s.hessian() @ x.reshape(-1, 6)
    np.testing.assert_allclose(xHx, np.einsum("ik,ik->k", x.reshape(-1, 6), ref), rtol=1e-12)
    np.testing.assert_allclose(out.reshape(-1, 6), ref, rtol=0, atol=1e-12 * np.abs(ref).max())
    # the diagonal blocks formed per contact are those of the assembled H
    Hd = s.hessian().toarray()
    for p in (0, 7, s.P - 1):
        np.testing.assert_allclose(s.diag_blocks[p], Hd[6 * p:6 * p + 6, 6 * p:6 * p + 6], rtol=0,
                                   atol=1e-12 * np.abs(Hd).max())


def test_compiled_cg_equals_the_numpy_block_cg(monkeypatch):
    """Same iteration, same tensor: the compiled kernel and the NumPy reference
    (``_solvers.block_cg`` on the assembled H) agree to 1e-9 and with SuperLU."""
    pytest.importorskip("grainmech.network._cg_kernel")
    net = random_network(200, seed=5)
    kn, ks, _ = contact_stiffnesses(net, shear_modulus=G, poisson=NU)
    fast = relaxed_stiffness(net, kn, ks, solver="cg", return_displacements=True)
    ref = relaxed_stiffness(net, kn, ks, solver="superlu")
    monkeypatch.setattr(rel, "_KERNEL", False)
    slow = relaxed_stiffness(net, kn, ks, solver="cg", return_displacements=True)
    scale = np.abs(ref.C_relaxed).max()
    assert fast.solver == slow.solver == "cg"
    assert abs(fast.iterations - slow.iterations) <= 1
    assert fast.residual <= 1e-7 and slow.residual <= 1e-7
    np.testing.assert_allclose(fast.C_relaxed, slow.C_relaxed, rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(fast.C_relaxed, ref.C_relaxed, rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(fast.displacements, slow.displacements, rtol=0,
                               atol=1e-7 * np.abs(slow.displacements).max())


def test_compiled_auto_falls_back_like_the_reference(monkeypatch):
    """auto with a tiny CG budget: the compiled CG stops after its prediction and the
    factorisation runs, as with the NumPy reference."""
    pytest.importorskip("grainmech.network._cg_kernel")
    from grainmech.network import _solvers

    net = random_network(100, seed=5)
    kn, ks, _ = contact_stiffnesses(net, shear_modulus=G, poisson=NU)
    monkeypatch.setattr(rel, "AUTO_CG_MAXITER", 5)
    r = relaxed_stiffness(net, kn, ks)
    assert r.solver == _solvers.choose("auto", 6 * r.n_particles) and r.residual <= 1e-7


@pytest.mark.parametrize("name", ["auto", "direct", "pardiso", "cholesky", "superlu", "amg", "cg"])
def test_config_accepts_every_solver_name_of_the_library(name, monkeypatch):
    from grainmech.io.config import Section
    from grainmech.jobs import dem_options
    from grainmech.network import _solvers

    monkeypatch.setattr(_solvers, "available", lambda method: True)
    assert dem_options(Section({"relaxed": {"solver": name}}, "material"))["solver"] == name


def test_config_rejects_unknown_and_uninstalled_solvers(monkeypatch):
    from grainmech.errors import ConfigError
    from grainmech.io.config import Section
    from grainmech.jobs import dem_options
    from grainmech.network import _solvers

    with pytest.raises(ConfigError, match=r"material\.relaxed\.solver.*'mumps'.*must be one of 'auto', 'direct', "
                                          r"'pardiso', 'cholesky', 'superlu', 'amg', 'cg'"):
        dem_options(Section({"relaxed": {"solver": "mumps"}}, "material"))
    monkeypatch.setattr(_solvers, "available", lambda method: method != "pardiso")
    with pytest.raises(ConfigError, match=r"material\.relaxed\.solver.*'pardiso'.*needs the optional package "
                                          r"pypardiso"):
        dem_options(Section({"relaxed": {"solver": "pardiso"}}, "material"))


def test_block_inverses_and_the_singular_blocks():
    kernel = pytest.importorskip("grainmech.network._cg_kernel")
    rng = np.random.default_rng(3)
    A = rng.normal(size=(5, 6, 6))
    D = A @ A.transpose(0, 2, 1) + 0.1 * np.eye(6)
    D[2] = np.diag([1.0, 2, 3, 4, 5, 0])  # a free rotation
    D[4] = 0.0
    inv, bad = kernel.block_inverses(D, 1e-8)
    assert bad.tolist() == [False, False, True, False, True]
    for g in (0, 1, 3):
        np.testing.assert_allclose(inv[g] @ D[g], np.eye(6), atol=1e-9)


def test_block_inverses_flag_the_numerically_singular_blocks_of_a_network():
    """A grain whose contacts leave one rotation free has a singular 6x6 block; its last
    Cholesky pivot is a rounding residue (up to ~1e-11 of the diagonal in this network),
    which must not be inverted."""
    kernel = pytest.importorskip("grainmech.network._cg_kernel")
    net = random_network(2000, coordination=7.0, seed=1)
    kn, ks, _ = contact_stiffnesses(net, shear_modulus=G, poisson=NU)
    nrm = net.normals
    rA, rB = net.radii[net.i][:, None] * nrm, -net.radii[net.j][:, None] * nrm
    D = rel._assemble(net.n_particles, net.i, net.j, nrm, net.branch, kn, ks, rA, rB, rotations=True).diag_blocks
    inv, bad = kernel.block_inverses(D, 1e-8)
    err = np.abs(inv[~bad] @ D[~bad] - np.eye(6)).max()
    assert err < 1e-6
    ev = np.linalg.eigvalsh(D[bad])
    assert np.all(ev[:, 0] <= 1e-7 * np.abs(ev).max(axis=1))  # the flagged ones are (nearly) singular


def _floppy_network():
    """300 grains at coordination 5: H has one near-floppy mode (eigenvalue ~5e-13 of the
    largest, dense eigendecomposition) that holds 0.8 % of the tensor's correction. The
    1e-10 diagonal shift of the factorisations hides it; iterative refinement with the
    shifted factor stalled there at a relative residual of 1.7e-8 with the tensor off by
    7.9e-3 (docs/performance.md)."""
    net = random_network(300, coordination=5.0, seed=0)
    kn, ks, _ = contact_stiffnesses(net, shear_modulus=G, poisson=NU)
    return net, kn, ks


@pytest.mark.parametrize("name", ["superlu", "pardiso", "cholesky", "auto"])
def test_factorisations_resolve_the_near_floppy_modes(name):
    """Every direct solve is refined by CG preconditioned by its factor until the true
    residual is below 1e-10: the tensor equals that of block CG (an independent method
    that needs no shift) run to 1e-11."""
    from grainmech.network import _solvers

    if not _solvers.available(name):
        pytest.skip(f"{name} not installed")
    net, kn, ks = _floppy_network()
    ref = relaxed_stiffness(net, kn, ks, solver="cg", tol=1e-11, maxiter=100000)
    r = relaxed_stiffness(net, kn, ks, solver=name)
    assert r.residual <= 1e-9
    scale = np.abs(ref.C_relaxed).max()
    np.testing.assert_allclose(r.C_relaxed, ref.C_relaxed, rtol=0, atol=1e-6 * scale)


def test_amg_runs_cg_on_the_unshifted_hessian():
    """AMG-preconditioned CG (optional package pyamg) solves the shifted Hessian, then is
    refined like a factorisation (CG on the Hessian itself preconditioned by the V-cycle,
    to the true residual 1e-10): on the network with near-floppy modes its tensor equals
    block CG's at 1e-11. Unrefined (commit 145c694) it returned a tensor 8.0e-3 off without
    a word: its residual, 5.1e-8, passed the check (up to 1e-6)."""
    pytest.importorskip("pyamg")
    net, kn, ks = _floppy_network()
    ref = relaxed_stiffness(net, kn, ks, solver="cg", tol=1e-11, maxiter=100000)
    r = relaxed_stiffness(net, kn, ks, solver="amg")
    assert r.solver == "amg" and r.residual <= 1e-9
    np.testing.assert_allclose(r.C_relaxed, ref.C_relaxed, rtol=0, atol=1e-6 * np.abs(ref.C_relaxed).max())


def test_unrefined_factorisation_is_reported_not_returned(monkeypatch):
    """Without refinement steps the factorisation stays at its stalled residual: a named
    direct solver raises, ``auto`` runs block CG instead and says so."""
    net, kn, ks = _floppy_network()
    monkeypatch.setattr(rel, "DIRECT_REFINE_STEPS", 0)
    with pytest.raises(rel.GrainmechError, match=r"solver 'superlu'.*left a relative residual .* above 1e-10"):
        relaxed_stiffness(net, kn, ks, solver="superlu")
    r = relaxed_stiffness(net, kn, ks)
    ref = relaxed_stiffness(net, kn, ks, solver="cg", tol=1e-11, maxiter=100000)
    assert r.solver == "cg" and r.residual <= 1e-7
    np.testing.assert_allclose(r.C_relaxed, ref.C_relaxed, rtol=0, atol=1e-6 * np.abs(ref.C_relaxed).max())


def test_refine_pcg_removes_the_error_left_in_soft_modes():
    """``refine_pcg`` on a diagonal SPD matrix with three soft eigenvalues far below the
    shift of its preconditioner ``(A + s I)^-1``: the refined solution is the exact one
    (``x = b / a``), in about one step per soft mode, where the plain refinement step
    ``x += M r`` would shrink the error there by only ``s / (a + s)`` per step."""
    import scipy.sparse as sp

    from grainmech.network import _solvers

    a = np.r_[np.linspace(1.0, 2.0, 200), 1e-13, 3e-13, 1e-12]
    b = np.ones((a.size, 2))
    b[:, 1] = np.arange(a.size) % 3 + 1.0
    s = 1e-10
    A = sp.diags(a).tocsr()

    def solve(r):
        return r / (a + s)[:, None]

    X, steps, res = _solvers.refine_pcg(A, b, solve(b), solve, 1e-12, 20)
    assert res.max() <= 1e-12 and steps <= 6
    np.testing.assert_allclose(X, b / a[:, None], rtol=1e-8)


def test_pardiso_handle_finds_mkl_from_the_mkl_package(monkeypatch):
    """pardiso_solver names pypardiso's MKL runtime from the ``mkl`` distribution's files
    (instead of find_library and a recursive glob); the handle factors and solves; a
    value the user set is kept. The solve runs on one MKL thread (``one_mkl_thread``, as
    every factor of grainmech): multithreaded, it failed with PARDISO error -3 after the
    rest of the suite had run MKL and numba's threads in this process."""
    pytest.importorskip("pypardiso")
    import os

    import scipy.sparse as sp

    from grainmech.network._solvers import one_mkl_thread, pardiso_solver

    monkeypatch.delenv("PYPARDISO_MKL_RT", raising=False)
    s = pardiso_solver(2)
    path = os.environ.get("PYPARDISO_MKL_RT")
    assert path is not None and os.path.isfile(path) and "mkl_rt" in os.path.basename(path)
    A = sp.csr_matrix(np.array([[4.0, 1.0], [1.0, 3.0]]))
    with one_mkl_thread(s):
        x = s.solve(sp.triu(A, format="csr"), np.array([1.0, 2.0]))
    np.testing.assert_allclose(A @ x, [1.0, 2.0], rtol=1e-12)
    s.free_memory(everything=True)
    mine = os.path.join(os.path.dirname(path), ".", os.path.basename(path))  # the same file, another name
    monkeypatch.setenv("PYPARDISO_MKL_RT", mine)
    pardiso_solver(2).free_memory(everything=True)
    assert os.environ["PYPARDISO_MKL_RT"] == mine
