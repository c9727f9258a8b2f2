"""Checking the authentication codes recorded in a run's bag (``./pd replay --key``).

Every command the integrator sent and every feedback it took went through the site's topics
with a MAC over their bytes (:mod:`pd_common.auth`); the bag records them with their header
stamps and signatures, so their bytes are made again exactly (:mod:`pd_common.protocol.cdr`)
and each MAC can be checked again with the key: a bag whose commands or feedback were altered
after the test (or that mixes streams of another key) shows it. The key is needed only for this
check; the replay itself does not need it.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from pd_common.auth import AuthError, Key, command_payload, feedback_payload, verify_mac
from pd_common.protocol import (
    CdrEncodeError,
    Command,
    Feedback,
    Signature,
    covered_part,
    encode_command,
    encode_feedback,
)

if TYPE_CHECKING:
    from .bag import RecordedRun

__all__ = ['ForeignKeyError', 'SignatureCheck', 'check_signatures']


class ForeignKeyError(AuthError):
    """No recorded message names the key given to check a run's signatures.

    Its check would count every signed message as failed: most likely the wrong key file
    (or a record whose messages were all re-signed with another key), so it is refused
    before anything is written, rather than reported as that many altered messages.
    """


@dataclass(frozen=True)
class SignatureCheck:
    """What checking a bag's recorded signatures found.

    Attributes:
        verified: messages whose MAC matches their recorded fields.
        failed: messages whose MAC does not match (altered, or another key).
        unsigned: messages recorded without a signature (a run without authentication).
        key_id: id of the key used.
    """

    verified: int
    failed: int
    unsigned: int
    key_id: str

    @property
    def ok(self) -> bool:
        """Whether no recorded signature failed."""
        return self.failed == 0

    def as_dict(self) -> dict[str, object]:
        """For ``summary.json``."""
        return {'key_id': self.key_id, 'verified': self.verified, 'failed': self.failed,
                'unsigned': self.unsigned}


def _streams(run: RecordedRun) -> Iterable[tuple[Command | Feedback, Signature, int]]:
    """The messages that went over the sites' topics, with their signatures and stamps."""
    if run.site_events:  # a substructured test: the structure stream is internal, unsigned
        for site, events in run.site_events.items():
            yield from zip((item for _, item in events), run.site_signatures[site],
                           run.site_stamps[site], strict=True)
    else:
        yield from zip((item for _, item in run.events), run.signatures, run.stamps,
                       strict=True)


def check_signatures(run: RecordedRun, key: Key) -> SignatureCheck:
    """Check the MAC of every recorded command and feedback with ``key``.

    Raises:
        ForeignKeyError: the run's messages are signed, and none names ``key`` (its id is in
            none of their signatures).
    """
    streams = list(_streams(run))
    recorded = {signature.key_id for _, signature, _ in streams if signature.signed}
    if recorded and key.key_id not in recorded:
        ids = ', '.join(sorted(recorded))
        msg = (f'none of the recorded messages names key {key.key_id} (they name {ids}): the '
               'wrong key file, or messages re-signed with another key')
        raise ForeignKeyError(msg)
    verified = failed = unsigned = 0
    for item, signature, stamp_ns in streams:
        if not signature.signed:
            unsigned += 1
            continue
        # the bytes it travelled as, up to its MAC (the recorded MAC left out)
        bare = Signature(signature.key_id, signature.session, signature.sequence)
        try:
            if isinstance(item, Command):
                payload = command_payload(covered_part(encode_command(item, stamp_ns, bare)))
            else:
                payload = feedback_payload(covered_part(encode_feedback(item, stamp_ns, bare)))
        except CdrEncodeError:
            failed += 1
            continue
        if verify_mac(key, payload, signature) is None:
            verified += 1
        else:
            failed += 1
    return SignatureCheck(verified=verified, failed=failed, unsigned=unsigned,
                          key_id=key.key_id)
