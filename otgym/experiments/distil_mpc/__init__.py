"""The MPC distilled into a policy network (``otgym experiment distil-mpc``)."""
