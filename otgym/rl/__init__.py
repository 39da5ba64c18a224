"""Reinforcement learning over the functional environments: a pure-JAX DQN
(``dqn``), its Q-network (``network``) and policy files (``policy``)."""
