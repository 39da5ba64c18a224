"""The distributed runtime: otgym's messages as ROS 2 types in CDR (``messages``) and
their transport between processes over eclipse-zenoh (``transport``, ``nodes``)."""
