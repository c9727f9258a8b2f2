"""The console believes a test definition only as the integrator's signed status names it."""

from __future__ import annotations

import hashlib
import json

from pd_common.protocol import definition_digest
from pd_console.core import DEFINITIONS_KEPT, DefinitionWitness

GENUINE = json.dumps({'test': {'id': 'column'}, 'sites': {'': {'bridge': {'max_stroke': 0.05}}}})
FORGED = json.dumps({'test': {'id': 'column'}, 'sites': {'': {'bridge': {'max_stroke': 9.0}}}})


def test_the_digest_is_the_sha256_of_the_json_text() -> None:
    assert definition_digest(GENUINE) == hashlib.sha256(GENUINE.encode()).hexdigest()
    assert definition_digest('é') == hashlib.sha256('é'.encode()).hexdigest()
    assert definition_digest(GENUINE) != definition_digest(FORGED)


def test_a_definition_no_genuine_status_names_is_never_shown() -> None:
    witness = DefinitionWitness(authenticated=True)
    assert witness.heard(FORGED) is None                   # a rogue's, before any status
    assert witness.named(definition_digest(GENUINE)) is None  # the status first ...
    assert witness.missing
    assert witness.heard(GENUINE) == GENUINE               # ... then its definition: shown
    assert not witness.missing
    assert witness.heard(FORGED) is None                   # a later forgery: not shown
    assert witness.named(definition_digest(GENUINE)) is None  # (shown once)
    assert witness.heard(GENUINE) is None
    assert witness.believed == definition_digest(GENUINE)


def test_the_definition_first_then_the_status_that_names_it() -> None:
    witness = DefinitionWitness(authenticated=True)
    assert not witness.missing                             # nothing named yet
    assert witness.heard(GENUINE) is None
    assert witness.heard(FORGED) is None
    assert witness.named('') is None                        # a bridge's status names none
    assert witness.named(definition_digest(GENUINE)) == GENUINE
    assert not witness.missing
    # A new test (another integrator): its status names its own definition.
    assert witness.named(definition_digest(FORGED)) == FORGED


def test_a_flood_of_unnamed_definitions_keeps_only_the_last_few() -> None:
    witness = DefinitionWitness(authenticated=True)
    witness.heard(GENUINE)
    for n in range(100):
        witness.heard(json.dumps({'n': n}))
    assert witness.named(definition_digest(GENUINE)) is None  # pushed out by the flood
    assert witness.missing                                    # (the node reads it again)
    last = json.dumps({'n': 99})
    assert witness.named(definition_digest(last)) == last
    assert witness.named(definition_digest(json.dumps({'n': 99 - DEFINITIONS_KEPT}))) is None
    assert witness.heard(GENUINE) is None  # (no longer named: the last status named another)


def test_without_a_key_the_last_definition_heard_is_shown() -> None:
    witness = DefinitionWitness(authenticated=False)
    assert witness.heard(GENUINE) == GENUINE
    assert witness.heard(GENUINE) is None
    assert witness.heard(FORGED) == FORGED
    assert witness.named(definition_digest(GENUINE)) is None
