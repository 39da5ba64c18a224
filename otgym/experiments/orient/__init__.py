"""Episodes of the ``orient`` task under a policy, and its report outcomes."""
