"""Contact laws of grainmech (seed Chapter 3 and beyond).

Parameters (frozen, self-validating dataclasses, :mod:`grainmech.contact.params`):
:class:`Hertz`, :class:`HertzMindlin`, :class:`MindlinDeresiewicz`, :class:`LinearSpring`,
:class:`Cylinder`.

Closed-form geometry and stiffness (:mod:`grainmech.contact.geometry`), e.g.
:func:`hertz_normal_force`, :func:`hertz_contact_radius_from_force`,
:func:`hertz_normal_stiffness`, :func:`mindlin_tangential_stiffness`,
:func:`cylinder_normal_stiffness`, :func:`cylinder_tangential_stiffness`.

Incremental laws (:mod:`grainmech.contact.law`): :func:`initial_state`,
:func:`state_from_normal_force`, :func:`update` returning
``(ContactState, ContactResponse)``.

One interface for the drivers (:mod:`grainmech.contact.interface`):
:class:`ContactLawProtocol`, implemented by :class:`ContactLaw`.

Analytic Mindlin–Deresiewicz references (:mod:`grainmech.contact.analytic`) and a
force-controlled step solver (:mod:`grainmech.contact.control`).

See ``docs/contact-laws.md`` for the physics, the 3D treatment and the memory depth.
"""

from grainmech.contact._errors import ContactDomainError, ReversalMemoryError
from grainmech.contact.analytic import (
    md_dissipation_per_cycle,
    md_loading_displacement,
    md_loading_force,
    md_unloading_displacement,
    md_unloading_force,
)
from grainmech.contact.control import solve_step
from grainmech.contact.forms import LawForms, law_forms
from grainmech.contact.geometry import (
    cylinder_approach_from_force,
    cylinder_contact_halfwidth,
    cylinder_normal_force,
    cylinder_normal_stiffness,
    cylinder_tangential_stiffness,
    hertz_approach_from_force,
    hertz_contact_radius,
    hertz_contact_radius_from_force,
    hertz_normal_force,
    hertz_normal_stiffness,
    hertz_normal_stiffness_from_approach,
    mindlin_tangential_stiffness,
    mindlin_tangential_stiffness_from_force,
)
from grainmech.contact.interface import ContactLaw, ContactLawProtocol, make_law
from grainmech.contact.law import (
    ContactResponse,
    ContactState,
    compiled_kernel,
    initial_state,
    law_kind,
    max_reversals,
    reversal_forces,
    state_from_approach,
    state_from_forces,
    state_from_normal_force,
    update,
)
from grainmech.contact.params import (
    Cylinder,
    Hertz,
    HertzMindlin,
    LinearSpring,
    MindlinDeresiewicz,
)
from grainmech.contact.rolling import (
    RollingConstants,
    RollingResistance,
    rolling_constants,
    rolling_update,
)

__all__ = [
    "RollingResistance",
    "RollingConstants",
    "rolling_constants",
    "rolling_update",
    "ContactDomainError",
    "ReversalMemoryError",
    "Hertz",
    "HertzMindlin",
    "MindlinDeresiewicz",
    "LinearSpring",
    "Cylinder",
    "ContactState",
    "ContactResponse",
    "initial_state",
    "state_from_normal_force",
    "state_from_approach",
    "state_from_forces",
    "update",
    "reversal_forces",
    "law_kind",
    "law_forms",
    "LawForms",
    "max_reversals",
    "compiled_kernel",
    "ContactLaw",
    "ContactLawProtocol",
    "make_law",
    "solve_step",
    "hertz_normal_force",
    "hertz_contact_radius",
    "hertz_contact_radius_from_force",
    "hertz_approach_from_force",
    "hertz_normal_stiffness",
    "hertz_normal_stiffness_from_approach",
    "mindlin_tangential_stiffness",
    "mindlin_tangential_stiffness_from_force",
    "cylinder_contact_halfwidth",
    "cylinder_normal_stiffness",
    "cylinder_approach_from_force",
    "cylinder_normal_force",
    "cylinder_tangential_stiffness",
    "md_loading_displacement",
    "md_loading_force",
    "md_unloading_displacement",
    "md_unloading_force",
    "md_dissipation_per_cycle",
]
