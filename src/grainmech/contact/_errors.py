"""Exceptions raised by the contact laws."""

from __future__ import annotations

import numpy as np

from grainmech.errors import GrainmechError

__all__ = ["ReversalMemoryError", "ContactDomainError"]


class ReversalMemoryError(GrainmechError):
    """A loading path needs more remembered load reversals than the state can hold.

    Raised by :func:`grainmech.contact.update` for the Mindlin–Deresiewicz and cylinder
    laws when a contact would have to remember more than ``max_reversals`` nested,
    still-open reversal points (see ``docs/contact-laws.md``, "Memory depth").
    """

    def __init__(self, contacts: np.ndarray, max_reversals: int) -> None:
        self.contacts = np.asarray(contacts)
        self.max_reversals = int(max_reversals)
        shown = ", ".join(str(int(i)) for i in self.contacts[:8])
        more = "" if self.contacts.size <= 8 else f" (and {self.contacts.size - 8} more)"
        super().__init__(
            f"max_reversals = {self.max_reversals}: contact(s) {shown}{more} need more "
            f"nested load reversals than the state remembers; increase max_reversals "
            f"(each level costs 8 bytes per contact)")


class ContactDomainError(GrainmechError):
    """A contact law was evaluated outside the range where its formula is valid."""
