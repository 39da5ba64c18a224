"""Distribution of the runtime's parts: otgym's topics as standard ROS 2 messages
(``messages``); the zenoh transport and nodes are to come (issue 12)."""
