r"""Compiled integration of fully strain-controlled paths (one pass over all steps).

When every component of every step is strain controlled, the kinematic hypothesis
(seed Eq. 2.13, ``delta_c = d eps . l_c``) gives each contact its displacement
increments directly: the contacts do not interact, no Newton iteration is needed, and
each contact's whole history can be integrated in one go. This module does exactly what
:func:`grainmech.driver.affine.solver.run` does step by step for such a path --

* the contact law: the compiled per-contact update of :mod:`grainmech.contact.kernel`
  (:func:`~grainmech.contact.kernel.rows`: Mindlin–Deresiewicz with the Thornton–Randall rules, seed Eq. 3.9–3.16;
  Hertz–Mindlin / linear springs with a Coulomb cap; frictionless Hertz), with the
  normal force from seed Eq. 3.6 (Hertz, ``N = 4/3 E* R*^(1/2) alpha^(3/2)``) or
  ``kn alpha`` and the contact radius from seed Eq. 3.2;
* the Love–Weber stress (seed Eq. 2.6, symmetric part);
* the tangent stiffness from the laws' ``kn``, ``ks`` (seed Eq. 2.26, the moments of
  :mod:`grainmech.assembly`);
* sliding and open fractions, dissipation, and the stored-energy estimate of
  :meth:`grainmech.contact.interface.ContactLaw.stored_energy`

-- but with the loop over steps inside the compiled code, chunk by chunk of contacts
(a ``prange`` over chunks; each chunk's state stays in cache for the whole path). The
results equal the step-by-step driver's to rounding (``tests/driver/test_affine_fused.py``).

Used automatically by :func:`~grainmech.driver.affine.solver.run` (``SolverOptions.compiled``)
for :class:`~grainmech.contact.interface.ContactLaw` points with a law the compiled kernel
supports, without the finite-deformation option. Anything the fast path cannot do
(another law, a contact needing more reversal memory than it has) falls back to the
step-by-step driver, which then reports the failure with its usual message.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from grainmech.assembly import add_moments3, moments_to_voigt
from grainmech.contact.kernel import (
    KernelConstants,
    KernelIncrement,
    KernelOutput,
    KernelScratch,
    KernelState,
    constants,
    rows,
)
from grainmech.contact.law import ContactResponse, ContactState
from grainmech.driver.affine._fold import fold as fold_rows
from grainmech.driver.affine._fold import path_mirrors, unfold
from grainmech.driver.affine._mixed_rows import (
    INNER,
    add_step_jacobian,
    contact_increment,
    love_weber_terms,
    stored_energy_term,
)

__all__ = ["strain_path"]

CHUNK = 128  # contacts per chunk (work item of the prange)
# the phases of the pass (one chunk's path, a step's sums, the accepted step): inlined by
# LLVM into the pass (``forceinline``), so that its code is the one loop nest it was
# written as (called instead, the constant-volume benchmark took 7-10 % longer)
_PHASE = {**INNER, "forceinline": True}


@njit(**_PHASE)
def _step_sums(ch, s, lo, c, normals, branch, weights, jrows, allc, any_rows, res, a, jac, r2, linear, ks_lin, R,
               Gs, stress_c, mom_c, scal_c, jac_c):
    """Chunk ``ch``'s sums of step ``s`` from the law's response ``res`` of its ``c`` contacts (from row ``lo``).

    The Love-Weber stress (seed Eq. 2.6, symmetric part), the moments of the tangent
    (seed Eq. 2.26 with the laws' ``kn``, ``ks``; :func:`grainmech.assembly.add_moments3`),
    the weighted sliding and open contacts, the dissipation, the stored energy
    (:meth:`~grainmech.contact.interface.ContactLaw.stored_energy`) and, for the rows
    ``jrows``, the consistent step tangent of the law (Newton); into
    ``stress_c[ch, s]``, ``mom_c[ch, s]``, ``scal_c[ch, s]``, ``jac_c[ch, s]``. ``a``
    (27,) and ``jac`` (36,) are work space, ``allc`` (6,) all True.
    """
    a_out, N_out, T_out, sl_out, diss_out, ks_out, kn_out, op_out, td_out, ta_out = (
        res.approach, res.normal_force, res.tangential_force, res.sliding, res.dissipation, res.ks, res.kn,
        res.open, res.t_delta, res.t_alpha)
    for q in range(27):
        a[q] = 0.0
    for q in range(36):
        jac[q] = 0.0
    sxx = 0.0
    syy = 0.0
    szz = 0.0
    syz = 0.0
    sxz = 0.0
    sxy = 0.0
    wsl = 0.0
    wop = 0.0
    wdi = 0.0
    wst = 0.0
    for j in range(c):
        i = lo + j
        w = weights[i]
        nx = normals[i, 0]
        ny = normals[i, 1]
        nz = normals[i, 2]
        lx = branch[i, 0]
        ly = branch[i, 1]
        lz = branch[i, 2]
        Nj = N_out[j]
        t0, t1, t2, t3, t4, t5 = love_weber_terms(Nj, T_out[j, 0], T_out[j, 1], T_out[j, 2], w,
                                                  nx, ny, nz, lx, ly, lz)
        sxx += t0
        syy += t1
        szz += t2
        syz += t3
        sxz += t4
        sxy += t5
        knj = kn_out[j] if kn_out[j] > 0.0 else 0.0
        ksj = ks_out[j] if ks_out[j] > 0.0 else 0.0
        cs = w * ksj
        add_moments3(a, nx, ny, nz, lx, ly, lz, w * knj - cs, cs, r2)
        if sl_out[j]:
            wsl += w
        if op_out[j]:
            wop += w
        wdi += w * diss_out[j]
        # stored energy (ContactLaw.stored_energy): normal + |T|^2 / (2 kt0)
        wst += w * stored_energy_term(Nj, a_out[j], T_out[j, 0], T_out[j, 1], T_out[j, 2], linear,
                                      ks_lin, R, Gs)
        if any_rows:
            # consistent (step) tangent of the law for Newton: jacobian rows
            add_step_jacobian(jac, 0, jrows, allc, w, kn_out[j], ta_out, td_out, j,
                              nx, ny, nz, lx, ly, lz)
    stress_c[ch, s, 0] = sxx
    stress_c[ch, s, 1] = syy
    stress_c[ch, s, 2] = szz
    stress_c[ch, s, 3] = syz
    stress_c[ch, s, 4] = sxz
    stress_c[ch, s, 5] = sxy
    for q in range(27):
        mom_c[ch, s, q] = a[q]
    scal_c[ch, s, 0] = wsl
    scal_c[ch, s, 1] = wop
    scal_c[ch, s, 2] = wdi
    scal_c[ch, s, 3] = wst
    if any_rows:
        for q in range(6):
            for q2 in range(6):
                jac_c[ch, s, q, q2] = jac[6 * q + q2]


@njit(**_PHASE)
def _accept_step(c, st_in, res):
    """Accept the step of ``c`` contacts: the law's output ``res`` becomes the state ``st_in`` (dissipation added)."""
    a_in, N_in, T_in, e_in, d_in, k_in, P_in, en_in = st_in
    nrev = P_in.shape[1]
    for j in range(c):
        a_in[j] = res.approach[j]
        N_in[j] = res.normal_force[j]
        for q in range(3):
            T_in[j, q] = res.tangential_force[j, q]
            e_in[j, q] = res.axis[j, q]
        d_in[j] = res.direction[j]
        k_in[j] = res.depth[j]
        for q in range(nrev):
            P_in[j, q] = res.reversals[j, q]
        en_in[j] = en_in[j] + res.dissipation[j]


@njit(**_PHASE)
def _chunk_path(ch, lo, hi, kcc, normals, branch, weights, dstrain, jrows, st, stress_c, mom_c, scal_c, jac_c,
                f_resp, fail, r2):
    """The whole path for chunk ``ch``, contacts ``lo <= i < hi``: per step the kinematics, the law, the sums.

    Per step: the contact increments (seed Eq. 2.13) and the normal law at the step's end
    (seed Eq. 3.6, 3.2; :func:`~grainmech.driver.affine._mixed_rows.contact_increment`),
    the law (:func:`~grainmech.contact.kernel.rows`), the chunk's sums
    (:func:`_step_sums`) and the accepted state (:func:`_accept_step`). ``st`` (the
    state arrays of every contact, a :class:`KernelState`) is advanced in place;
    ``f_resp`` (the response arrays ``f_slide ... f_ta`` of every contact) receives the
    last step's response; ``fail[ch]`` the step at which the law could not advance a
    contact (the chunk stops there).
    """
    c = hi - lo
    m = dstrain.shape[0]
    nrev = st.reversals.shape[1]
    linear, E, R, Gs, kn_lin, ks_lin = kcc.linear, kcc.E, kcc.R, kcc.Gs, kcc.kn_lin, kcc.ks_lin
    st_in = KernelState(
        st.approach[lo:hi], st.normal_force[lo:hi], st.tangential_force[lo:hi], st.axis[lo:hi],
        st.direction[lo:hi], st.depth[lo:hi], st.reversals[lo:hi], st.dissipated_energy[lo:hi])
    f_slide, f_diss, f_ks, f_ksp, f_ktn, f_kn, f_open, f_td, f_ta = f_resp
    a_in, N_in = st_in.approach, st_in.normal_force
    res = KernelOutput(np.empty(c), np.empty(c), np.empty((c, 3)), np.empty((c, 3)), np.empty(c, dtype=np.int8),
                       np.empty(c, dtype=np.int32), np.empty((c, nrev)), f_slide[lo:hi], f_diss[lo:hi],
                       f_ks[lo:hi], f_ksp[lo:hi], f_ktn[lo:hi], f_kn[lo:hi], f_open[lo:hi], f_td[lo:hi],
                       f_ta[lo:hi])
    dn = np.empty(c)
    dt = np.empty((c, 3))
    N1 = np.empty(c)
    rad0 = np.empty(c)
    rad1 = np.empty(c)
    inc = KernelIncrement(dn, dt, N1, rad0, rad1)
    scratch = KernelScratch(np.empty((c, 3)), np.empty((c, 3)), np.zeros(c, dtype=np.int8), np.empty((c, 0)))
    flags = scratch.flags
    a = np.zeros(27)
    jac = np.zeros(36)
    allc = np.ones(6, dtype=np.bool_)
    any_rows = False
    for q in range(6):
        if jrows[q]:
            any_rows = True
    for s in range(m):
        exx = dstrain[s, 0]
        eyy = dstrain[s, 1]
        ezz = dstrain[s, 2]
        eyz = 0.5 * dstrain[s, 3]
        exz = 0.5 * dstrain[s, 4]
        exy = 0.5 * dstrain[s, 5]
        for j in range(c):
            i = lo + j
            dn[j], dt[j, 0], dt[j, 1], dt[j, 2], N1[j], rad0[j], rad1[j] = contact_increment(
                exx, eyy, ezz, eyz, exz, exy, normals[i, 0], normals[i, 1], normals[i, 2],
                branch[i, 0], branch[i, 1], branch[i, 2], a_in[j], N_in[j], linear, kn_lin, E, R)
        rows(0, c, kcc, st_in, inc, res, scratch)
        bad = False
        for j in range(c):
            if flags[j] != 0:
                bad = True
        if bad:
            fail[ch] = s
            break
        _step_sums(ch, s, lo, c, normals, branch, weights, jrows, allc, any_rows, res, a, jac, r2, linear, ks_lin,
                   R, Gs, stress_c, mom_c, scal_c, jac_c)
        _accept_step(c, st_in, res)


def _make(parallel: bool):
    """The pass compiled serial or parallel (``prange`` over chunks); same bits either way.

    A closure over ``rng`` (as in :mod:`grainmech.contact.kernel`): two dispatchers of one
    plain function would share numba's on-disk cache entry and the "parallel" one would
    load the serial code. Each chunk runs the whole path in :func:`_chunk_path`.
    """
    rng = prange if parallel else range

    def _strain_path_body(kc, normals, branch, weights, dstrain, jrows,
                          alpha, N, T, e, direction, depth, P, energy,
                          stress_c, mom_c, scal_c, jac_c,
                          f_slide, f_diss, f_ks, f_ksp, f_ktn, f_kn, f_open, f_td, f_ta, fail):
        # the state arrays (alpha ... energy) are advanced in place; f_* receive the
        # response of the last step
        n = alpha.shape[0]
        nch = (n + CHUNK - 1) // CHUNK
        r2 = math.sqrt(2.0) / 2.0
        # plain values into the (parallel) loop; the named tuple is rebuilt inside
        (law, linear, E, R, Gs, kn_lin, ks_lin, mu, mu_finite, r, p, m_exp, maxrev, hcoef, gcoef,
         glx, glw, sph, k8) = kc
        for ch in rng(nch):
            lo = ch * CHUNK
            hi = min(n, lo + CHUNK)
            kcc = KernelConstants(law, linear, E, R, Gs, kn_lin, ks_lin, mu, mu_finite, r, p, m_exp,
                                  maxrev, hcoef, gcoef, glx, glw, sph, k8)
            _chunk_path(ch, lo, hi, kcc, normals, branch, weights, dstrain, jrows,
                        KernelState(alpha, N, T, e, direction, depth, P, energy), stress_c, mom_c, scal_c, jac_c,
                        (f_slide, f_diss, f_ks, f_ksp, f_ktn, f_kn, f_open, f_td, f_ta), fail, r2)
    return njit(parallel=parallel, cache=True, error_model="numpy")(_strain_path_body)


_kernel_serial = _make(False)
_kernel_parallel = _make(True)


#: rows from which the pass runs on numba's threads (with more than one): the whole path is
#: one parallel region, so the threads pay early; on 2 cores the threaded run took
#: 0.95-0.98x the serial one's speed at 64-128 rows and was 1.5-1.9x faster from 256 rows
#: on (random sets, 2 cycles of constant-volume simple shear; ``docs/performance.md``)
PARALLEL_ROWS = 256


def _strain_path_kernel(*args):
    """The compiled pass, parallel or serial by the number of rows.

    Parallel from :data:`PARALLEL_ROWS` rows (and more than one numba thread), serial
    below: for small sets the threads' start-up (and, on a busy machine, waiting for a
    free core) costs more than the work.
    """
    from numba import get_num_threads

    n = args[1].shape[0]  # normals (after the law constants)
    parallel = n >= PARALLEL_ROWS and get_num_threads() > 1
    return (_kernel_parallel if parallel else _kernel_serial)(*args)


def strain_path(point, d_strain: np.ndarray, jacobian_rows: np.ndarray | None = None, fold: bool = True):
    """Integrate strain increments ``d_strain`` (m, 6) from ``point`` in one compiled pass.

    Parameters
    ----------
    point : MaterialPoint
        With a :class:`~grainmech.contact.interface.ContactLaw` whose parameters the compiled
        kernel supports (the caller checks).
    d_strain : (m, 6) strain increments (engineering shear, library order)
    jacobian_rows : (6,) bool, optional
        Rows of the consistent (non-symmetric) tangent ``sum w B^T K B`` to assemble at
        each step, ``K`` the law's step tangent (``ContactResponse.t_delta``,
        ``t_alpha``; :func:`grainmech.driver.affine._mixed_rows.add_step_jacobian`) (for Newton).
    fold : bool
        Evaluate one row per orbit of the symmetries of the contact set, the state and the
        path (the antipodal map, mirrors through coordinate planes whose odd shear
        components the path leaves at zero), with the orbit's weight
        (:mod:`grainmech.driver.affine._fold`); the state and response returned are unfolded.

    Returns
    -------
    dict or None
        Per-step arrays (m, ...) ``stress`` (Love–Weber, without ``point.correction``),
        ``tangent`` (Voigt), ``sliding``, ``open`` (weighted fractions), ``dissipation``
        (per step), ``stored``; and ``state``, ``response`` of the last step. ``None``
        when a contact needs more reversal memory than it has (the caller then reruns the
        path step by step, which reports where).
    """
    cs = point.contacts
    params = point.law.params
    consts = constants(params)
    # one row per orbit of the symmetries of the rows, the state and the path (driver/_fold.py)
    folding, normals, branch, weights, st, _ = fold_rows(cs, point.state, point.response, fold,
                                                         path_mirrors(np.zeros(6, dtype=bool), d_strain))
    n = normals.shape[0]
    m = d_strain.shape[0]
    nch = (n + CHUNK - 1) // CHUNK

    def c(x, dtype=float):
        x = np.ascontiguousarray(x, dtype=dtype)
        return x if x.flags.writeable else x.copy()

    stress_c = np.zeros((nch, m, 6))
    mom_c = np.zeros((nch, m, 27))
    scal_c = np.zeros((nch, m, 4))
    # the state, copied: the kernel advances it in place
    state = ContactState(*(np.array(x, dtype=dt, order="C") for x, dt in zip(
        st, (float, float, float, float, np.int8, np.int32, float, np.bool_, float))))
    f_diss, f_ks, f_ksp, f_ktn, f_kn = (np.empty(n) for _ in range(5))
    f_slide = np.empty(n, dtype=np.bool_)
    f_open = np.empty(n, dtype=np.bool_)
    f_td = np.empty((n, 3, 3))
    f_ta = np.empty((n, 3))
    fail = np.full(nch, -1, dtype=np.int64)
    jrows = (np.zeros(6, dtype=np.bool_) if jacobian_rows is None
             else np.ascontiguousarray(jacobian_rows, dtype=np.bool_))
    jac_c = np.zeros((nch, m, 6, 6)) if jrows.any() else np.zeros((1, 1, 6, 6))
    _strain_path_kernel(consts, c(normals), c(branch), c(weights), c(d_strain), jrows,
                        state.approach, state.normal_force, state.tangential_force, state.axis,
                        state.direction, state.depth, state.reversals, state.dissipated_energy,
                        stress_c, mom_c, scal_c, jac_c,
                        f_slide, f_diss, f_ks, f_ksp, f_ktn, f_kn, f_open, f_td, f_ta, fail)
    if np.any(fail >= 0):
        return None
    stress = stress_c.sum(axis=0)
    mom = mom_c.sum(axis=0)
    scal = scal_c.sum(axis=0)
    wtot = float(weights.sum())
    frac = scal[:, :2] / wtot if wtot > 0 else np.zeros((m, 2))
    tangent = np.array([moments_to_voigt(mom[k]) for k in range(m)])
    state = state._replace(sliding=f_slide)
    jac = jac_c.sum(axis=0) if jrows.any() else np.zeros((m, 6, 6))
    if folding is not None:
        state = type(state)(*(unfold(folding, x, name) for name, x in zip(state._fields, state)))
        f_slide, f_open = state.sliding, unfold(folding, f_open)
        f_kn, f_ks, f_ksp, f_ktn, f_diss = (unfold(folding, x) for x in (f_kn, f_ks, f_ksp, f_ktn, f_diss))
        f_td = unfold(folding, f_td, "t_delta")  # dT/d delta: entry ab times g_a g_b
        f_ta = unfold(folding, f_ta, "t_alpha")  # dT/d alpha: mapped as T
        # the components the group does not leave invariant sum to zero over each orbit
        sym = folding.sym
        stress = stress * sym[:6]
        tangent = tangent * sym[6:].reshape(6, 6)
        jac = jac * sym[6:].reshape(6, 6)
    response = ContactResponse(state.normal_force, state.tangential_force, f_kn, f_ks, f_ksp, f_ktn,
                               state.axis, f_slide, f_open, f_diss, f_td, f_ta)
    return {"stress": stress, "tangent": tangent, "jacobian": jac, "sliding": frac[:, 0], "open": frac[:, 1],
            "dissipation": scal[:, 2], "stored": scal[:, 3], "state": state, "response": response}
