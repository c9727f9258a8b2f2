"""Which test definition the console believes: the one a genuine status names.

The integrator publishes the resolved test definition (JSON) on ``test_definition`` as a plain
string and names its SHA-256 in every signed status
(:attr:`pd_common.protocol.Status.definition_digest`). Anyone on the domain can publish a
string on that topic, so with a key the console shows a definition — its sites, their labels
and the limits on its gauges — only once a status the integrator signed names its digest;
without a key (authentication off) it shows the last one heard, as before.
"""

from __future__ import annotations

from collections import OrderedDict

from pd_common.protocol import definition_digest

__all__ = ['DEFINITIONS_KEPT', 'DefinitionWitness']

#: Definitions heard but not (yet) named by a genuine status that are kept: a flood of forged
#: ones costs this many strings, never more (and may push the genuine one out before its
#: status arrives: :attr:`DefinitionWitness.missing` then tells the node to read it again).
DEFINITIONS_KEPT = 4


class DefinitionWitness:
    """The definitions heard and the digest the integrator's genuine status names.

    Args:
        authenticated: whether statuses are signed (a key is in use); without it every
            definition heard is believed.

    Attributes:
        believed: the digest of the definition handed out last (``None``: none yet).
    """

    def __init__(self, authenticated: bool) -> None:
        self.authenticated = authenticated
        self.believed: str | None = None
        self._named: str | None = None
        self._heard: OrderedDict[str, str] = OrderedDict()

    def heard(self, text: str) -> str | None:
        """A definition arrived: the text to show now, or ``None`` (not named, or shown)."""
        digest = definition_digest(text)
        if not self.authenticated or digest == self._named:
            return self._believe(digest, text)
        self._heard[digest] = text
        self._heard.move_to_end(digest)
        while len(self._heard) > DEFINITIONS_KEPT:
            self._heard.popitem(last=False)
        return None

    def named(self, digest: str) -> str | None:
        """A genuine status names ``digest``: the definition to show now, or ``None``."""
        if not self.authenticated or not digest:
            return None
        self._named = digest
        text = self._heard.get(digest)
        return None if text is None else self._believe(digest, text)

    @property
    def missing(self) -> bool:
        """Whether a genuine status named a definition that is neither shown nor held.

        (Not heard yet, or pushed out by others: the integrator's latched definition is worth
        reading again.)
        """
        return (self._named is not None and self._named != self.believed
                and self._named not in self._heard)

    def _believe(self, digest: str, text: str) -> str | None:
        if digest == self.believed:
            return None
        self.believed = digest
        return text
