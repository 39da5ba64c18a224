"""``Task.policy_shape``: a discrete task's observation size and number of actions from
its config alone, what a policy file is checked against before any work
(``otgym experiment TASK --policy``, ``otgym.experiments.task_report``). A task that
overrides it to skip building its params must give what its built params give."""

import pytest

from otgym import registry, tasks

pytestmark = pytest.mark.slow  # builds every registered task's params (about 10 CPU-s)


@pytest.mark.parametrize("name", registry.names("tasks"))
def test_the_shape_from_the_config_is_the_built_tasks(name):
    task = tasks.load(name)
    config = task.config()
    params = task.make_params(config)
    space = task.action_space(params)
    if not hasattr(space, "n"):
        with pytest.raises(ValueError, match="no discrete actions"):
            task.policy_shape(config)
        return
    assert task.policy_shape(config) == (task.observation_size(params), int(space.n))
