"""The Q-network: an MLP from observation to one value per discrete action (the
original release: 5 -> 128 -> 128 -> 10; here observation size -> 128 -> 128 -> N)."""

from __future__ import annotations

from collections.abc import Sequence

import flax.linen as nn


class QNetwork(nn.Module):
    n_actions: int
    hidden: Sequence[int] = (128, 128)

    @nn.compact
    def __call__(self, obs):
        x = obs
        for width in self.hidden:
            x = nn.relu(nn.Dense(width)(x))
        return nn.Dense(self.n_actions)(x)
