"""The runtime's parts outside one process: otgym's topics as standard ROS 2 messages
(``messages``) and MCAP recordings of sessions (``recording``; here and not in a
``record`` package because it shares the messages and the two layers are peers); the
zenoh transport and nodes are to come (issue 12)."""
