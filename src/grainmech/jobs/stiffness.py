"""``grainmech stiffness``: the stiffness tensor of an analytical fabric (seed Eq. 2.41)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from grainmech.elasticity import bulk_modulus, engineering_constants, shear_modulus, symmetry_class
from grainmech.io.config import Section
from grainmech.io.schema import build_fabric, build_law, build_microstructure, build_stress, microstructure_key
from grainmech.material import microstructure_stiffness
from grainmech.outcomes import StiffnessOutcome

__all__ = ["StiffnessSpec", "prepare_stiffness", "execute_stiffness", "compute_stiffness", "stiffness_scalars"]


@dataclass
class StiffnessSpec:
    """Objects read from a ``grainmech stiffness`` config."""

    density: Any
    microstructure: Any
    contacts: Any
    stress: Any
    fabric_fit: dict | None = None


def prepare_stiffness(cfg: dict, base_dir: str | Path | None = None) -> StiffnessSpec:
    """Read ``[microstructure]`` (``[packing]`` in older configs), ``[fabric]``, ``[contacts]``, ``[stress]``."""
    root = Section(cfg, "")
    fit: dict = {}
    density = build_fabric(root.section("fabric", {}), fit)
    stress = build_stress(root.section("stress", {}), density.dim)
    mean = None if stress is None else float(stress if np.ndim(stress) == 0 else np.trace(stress) / density.dim)
    ms = build_microstructure(root.section(microstructure_key(root)), density, mean)
    contacts = build_law(root.section("contacts"), ms.radius)
    root.finish()
    return StiffnessSpec(density, ms, contacts, stress, fit or None)


def execute_stiffness(spec: StiffnessSpec) -> StiffnessOutcome:
    """Stiffness tensor (seed Eq. 2.41), engineering constants and symmetry class."""
    res = microstructure_stiffness(spec.microstructure, spec.contacts, spec.stress)
    return StiffnessOutcome(res, engineering_constants(res.C), symmetry_class(res.C), spec.microstructure,
                            spec.density.dim, spec.fabric_fit)


def compute_stiffness(cfg: dict) -> StiffnessOutcome:
    """Config dict -> stiffness result (see :func:`execute_stiffness`); no printing."""
    return execute_stiffness(prepare_stiffness(cfg))


_ENGINEERING_3D = ("E_xx", "E_yy", "E_zz", "nu_xy", "nu_yx", "nu_xz", "nu_zx", "nu_yz", "nu_zy",
                   "G_yz", "G_xz", "G_xy")


_ENGINEERING_2D = ("E_xx", "E_yy", "nu_xy", "nu_yx", "G_xy")


def stiffness_scalars(out: StiffnessOutcome) -> dict[str, Any]:
    """Scalar outputs of a stiffness result: moduli [Pa], Poisson's ratios, symmetry.

    Columns: ``K_hill [Pa]``, ``G_hill [Pa]`` (Voigt-Reuss-Hill bulk and shear moduli),
    the engineering constants ``E_xx [Pa]`` ... ``nu_xy`` ... ``G_xy [Pa]`` (stable set,
    coupling coefficients omitted), ``symmetry`` (class name), ``mean_stress [Pa]`` and the
    Voigt components ``C11 [Pa]`` ... (upper triangle, library order).
    """
    C = np.asarray(out.result.C, dtype=float)
    dim = out.dim
    eng = out.engineering.as_dict()
    row: dict[str, Any] = {
        "K_hill [Pa]": float(bulk_modulus(C, "hill")),
        "G_hill [Pa]": float(shear_modulus(C, "hill")),
    }
    for k in (_ENGINEERING_3D if dim == 3 else _ENGINEERING_2D):
        row[f"{k} [Pa]" if k[0] in "EG" else k] = float(eng[k])
    row["symmetry"] = out.symmetry.name
    row["mean_stress [Pa]"] = out.mean_stress
    n = C.shape[0]
    for i in range(n):
        for j in range(i, n):
            row[f"C{i + 1}{j + 1} [Pa]"] = float(C[i, j])
    return row
