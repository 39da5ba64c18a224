"""``RemoteDevice``'s bookkeeping without a network: the callbacks the bus would call,
called in the orders the bus can deliver them."""

import numpy as np

from otgym.bus import messages as msg
from otgym.bus.nodes import RemoteDevice
from otgym.teleop.device import Sample


def twist(velocity_mm_s: float):
    """A twist message as the bus hands it to a subscriber (decoded)."""
    data = msg.twist(Sample(0, 0, np.zeros(3), (velocity_mm_s, 0, 0), 1), 1.0, "device0")
    return msg.decode(msg.twist_topic("device0"), data)


def test_a_twist_in_flight_when_the_node_is_lost_does_not_undo_its_rest_sample():
    """After the node's token goes, the rest sample stays the latest, however late a twist published before the loss arrives (found
    under load: the sim's worker kept a moving stylus of a node that had gone)."""
    samples = []
    remote = RemoteDevice(node=None, name="device0", on_sample=samples.append)
    remote._on_twist("t", twist(0.5), None)  # a peer without a token (yet) is taken
    assert remote.read().velocity_mm_s[0] == 0.5
    remote._on_liveliness("device0", True)
    remote._on_twist("t", twist(1.0), None)
    assert remote.read().velocity_mm_s[0] == 1.0
    remote._on_liveliness("device0", False)
    remote._on_twist("t", twist(2.0), None)  # late: published before the loss
    assert not remote.read().velocity_mm_s.any() and remote.losses == 1
    assert [s.velocity_mm_s[0] for s in samples] == [0.5, 1.0, 0.0]
    remote._on_liveliness("device0", True)  # the node is back: its twists count again
    remote._on_twist("t", twist(3.0), None)
    assert remote.read().velocity_mm_s[0] == 3.0
