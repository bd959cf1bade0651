"""A CANopen network (python-canopen) on the bus of an open CAN transport."""

from __future__ import annotations

import canopen

from devices.transports.can import CanTransport

#: Longest wait of the network's receive thread for a frame before it looks whether it is
#: to stop, s. python-canopen's 1 s made each close of a quiet bus (an adapter whose node
#: is gone, a node whose master is gone) wait up to a second for that thread.
NOTIFIER_CYCLE_S = 0.05


def canopen_network(transport: CanTransport) -> canopen.Network:
    """A connected :class:`canopen.Network` on ``transport``'s bus (opened before).

    ``network.disconnect()`` stops its receive thread within :data:`NOTIFIER_CYCLE_S`
    and shuts the bus down.
    """
    network = canopen.Network(transport.bus)
    network.NOTIFIER_CYCLE = NOTIFIER_CYCLE_S
    network.connect()
    return network
