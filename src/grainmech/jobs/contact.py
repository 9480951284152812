"""``grainmech contact``: one contact along a force/displacement path."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from grainmech.contact import solve_step, state_from_approach, state_from_normal_force
from grainmech.io.config import Section
from grainmech.io.reports import CONTACT_COLUMNS
from grainmech.io.schema import LAWS, build_contact_path, build_law, contact_units
from grainmech.outcomes import ContactOutcome

__all__ = ["ContactSpec", "prepare_contact", "execute_contact", "compute_contact"]


@dataclass
class ContactSpec:
    """A single contact, its initial state and its loading path (``grainmech contact``)."""

    params: Any
    initial: Any
    segments: list


def prepare_contact(cfg: dict, base_dir: str | Path | None = None) -> ContactSpec:
    """Read a ``grainmech contact`` config.

    ``[contact]`` (:func:`grainmech.io.schema.build_law`, every law), ``[initial]`` and
    ``[[path]]`` (:func:`grainmech.io.schema.build_contact_path`).
    """
    root = Section(cfg, "")
    params = build_law(root.section("contact"), None, laws=LAWS)
    initial, segments = build_contact_path(root, params)
    root.finish()
    return ContactSpec(params, initial, segments)


def execute_contact(spec: ContactSpec) -> ContactOutcome:
    """Drive the contact through the path, one :func:`grainmech.contact.solve_step` per step.

    Each ramp moves its controlled channels linearly from their current values to the
    targets; a held channel keeps its control mode. The tangential channel acts along x.
    """
    params, init = spec.params, spec.initial
    if init.mode == "force":
        st = state_from_normal_force(params, [init.value], dim=1)
    else:
        st = state_from_approach(params, [init.value], dim=1)
    _, r0, _, _ = solve_step(params, st, d_normal=[0.0])
    rows: list[tuple] = []
    delta = 0.0
    rows.append((0, -1, float(st.approach[0]), delta, float(st.normal_force[0]), 0.0, 0.0,
                 float(r0.kn[0]), float(r0.ks[0]), False))
    n_mode = init.mode
    t_mode = "disp"
    step = 0
    for seg in spec.segments:
        if seg.n_mode is not None:
            n_mode = seg.n_mode
        if seg.t_mode is not None:
            t_mode = seg.t_mode
        n0 = float(st.normal_force[0]) if n_mode == "force" else float(st.approach[0])
        t0 = float(st.tangential_force[0, 0]) if t_mode == "force" else delta
        n1 = seg.n_target if seg.n_mode is not None else n0
        t1 = seg.t_target if seg.t_mode is not None else t0
        for j in range(1, seg.steps + 1):
            f = j / seg.steps
            nv = n0 + f * (n1 - n0)
            tv = t0 + f * (t1 - t0)
            kw: dict[str, Any] = {}
            if n_mode == "force":
                kw["normal_force"] = [max(nv, 0.0)]
            else:
                kw["d_normal"] = [nv - float(st.approach[0])]
            if t_mode == "force":
                kw["tangential_force"] = [tv]
            else:
                kw["d_tangential"] = np.array([[tv - delta]])
            st, r, _, dt = solve_step(params, st, **kw)
            delta += float(dt[0, 0])
            step += 1
            rows.append((step, seg.index, float(st.approach[0]), delta, float(st.normal_force[0]),
                         float(st.tangential_force[0, 0]), float(st.dissipated_energy[0]),
                         float(r.kn[0]), float(r.ks[0]), bool(r.sliding[0])))
    cols = {name: np.array(col) for name, col in zip(CONTACT_COLUMNS, zip(*rows))}
    return ContactOutcome(cols, type(params).__name__, contact_units(params)[0])


def compute_contact(cfg: dict) -> ContactOutcome:
    """Config dict -> contact result (see :func:`execute_contact`)."""
    return execute_contact(prepare_contact(cfg))
