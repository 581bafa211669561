"""DDS on loopback only: every test here (and every process it starts) uses ``lo``, no multicast, and a random domain.

:data:`LOOPBACK_CONFIG` is set as ``CYCLONEDDS_URI`` and a random ``ROS_DOMAIN_ID`` (100-230) is chosen for the test
session before any test runs, so before any DDS participant exists (Cyclone reads its configuration when the first
participant of a process is created; child processes inherit both variables). Discovery is unicast to 127.0.0.1,
to the ports of participant indices 0-:data:`MAX_PARTICIPANTS` (``ParticipantIndex auto``), so nothing is sent on
another interface and no multicast is sent at all.
"""

from __future__ import annotations

import os
import random
from collections.abc import Iterator

import pytest

#: Participants one test session may have on the same domain at once (node, player, readers).
MAX_PARTICIPANTS = 20

#: The Cyclone DDS configuration of the tests (checked against Cyclone 11, the ``cyclonedds`` wheel's library).
LOOPBACK_CONFIG = (
    "<CycloneDDS><Domain Id='any'>"
    "<General><Interfaces><NetworkInterface name='lo'/></Interfaces><AllowMulticast>false</AllowMulticast></General>"
    "<Discovery><Peers><Peer address='127.0.0.1'/></Peers><ParticipantIndex>auto</ParticipantIndex>"
    f"<MaxAutoParticipantIndex>{MAX_PARTICIPANTS}</MaxAutoParticipantIndex></Discovery>"
    "</Domain></CycloneDDS>"
)

#: Valid DDS domain ids under the default port mapping stop at 232; 100-230 stays clear of the common 0.
DOMAIN_RANGE = (100, 230)


@pytest.fixture(scope="session", autouse=True)
def loopback_dds() -> Iterator[int]:
    """Set ``CYCLONEDDS_URI`` (loopback) and a random ``ROS_DOMAIN_ID`` for the whole test session; the domain id."""
    saved = {k: os.environ.get(k) for k in ("CYCLONEDDS_URI", "ROS_DOMAIN_ID")}
    domain = random.SystemRandom().randint(*DOMAIN_RANGE)
    os.environ["CYCLONEDDS_URI"] = LOOPBACK_CONFIG
    os.environ["ROS_DOMAIN_ID"] = str(domain)
    yield domain
    for k, v in saved.items():
        if v is None:
            os.environ.pop(k, None)
        else:
            os.environ[k] = v
