"""The one tiny DQN training configuration the tests share, so that its training chunk
(a scan over environment steps, the physics included: about 20 s to compile) compiles
once per test run and is read back from JAX's persistent cache everywhere else.

It is exactly what ``otgym train --steps 12800 --envs 64`` builds (``TRAIN_ARGS``), and
the member at penalty 100 and time cost 0.05 of ``otgym experiment speed-front --steps
12800`` (``FRONT_DQN`` has 64 environments; that member's reward is the ``paper``
preset's): two chunks of 100 iterations of 64 environments. Episodes end within it (a
random speed finishes a 15 um segment in at most 278 steps), and the Q-network learns
from the 79th iteration on (once the replay buffer holds ``learning_starts`` = 5000
transitions), so 122 of the 200 iterations update it."""

from otgym.rl.dqn import DQNConfig

TRAIN_ENVS = 64
TRAIN_STEPS = 12_800
TRAIN_CONFIG = DQNConfig(n_envs=TRAIN_ENVS, total_env_steps=TRAIN_STEPS)
TRAIN_ARGS = ["--steps", str(TRAIN_STEPS), "--envs", str(TRAIN_ENVS)]
LEARNING_FROM_ITERATION = -(-TRAIN_CONFIG.learning_starts // TRAIN_ENVS) - 1  # 0-based: the 79th iteration
