"""A ROS 2 topic of velocity commands feeding a ``TwistDevice`` (``otgym.teleop.twist``):
``geometry_msgs/msg/Twist`` or ``TwistStamped`` on ``/cmd_vel`` (by default), as
teleop_twist_keyboard (Twist) and teleop_twist_joy (Twist, or TwistStamped with
``publish_stamped_twist``) publish it. Each message passes the bus's checks
(``otgym.bus.intake``: type and hash, attachment, sequence, size, finite values
within range) before the device sees it; the device drops and counts what it cannot
use (non-finite) and clamps the speed."""

from __future__ import annotations

from otgym.bus import messages as msg
from otgym.bus.transport import Node
from otgym.teleop.twist import TwistDevice

DEFAULT_TOPIC = "/cmd_vel"
TYPES = (msg.TWIST, msg.TWIST_STAMPED)


def linear_m_s(message) -> tuple[float, float, float]:
    """The linear velocity of a Twist or a TwistStamped."""
    twist = message.twist if hasattr(message, "twist") else message
    return (twist.linear.x, twist.linear.y, twist.linear.z)


def attach(node: Node, device: TwistDevice, topic: str = DEFAULT_TOPIC) -> str:
    """Feed ``device`` from ``topic`` (resolved in the node's namespace); returns its
    fully qualified name."""
    return node.subscribe_ros(topic, TYPES, lambda name, message, data: device.feed(linear_m_s(message)))


def run_node(stop, endpoints: dict, name: str, ready, topic: str = DEFAULT_TOPIC) -> None:
    """A device node ``name`` driven by ``topic`` (``otgym node device --device twist``)
    until ``stop`` is set; ``ready(text)`` once it listens; prints what it did."""
    from otgym.bus.nodes import run_device_node

    driver = TwistDevice()
    with Node("device", name, **endpoints) as node:
        resolved = attach(node, driver, topic)
        ready(f"device {name} ({driver.caps.name} from {resolved})")
        published = run_device_node(node, driver, name, stop)
    print(
        f"device {name}: {published} samples published; {driver.received} commands applied, "
        f"{driver.dropped_nonfinite} non-finite dropped, {driver.clamped} clamped; "
        f"{sum(node.dropped.values())} messages dropped by the bus checks",
        flush=True,
    )
