"""``python -m tests.cluster.cluster_state ADDRESS``: Ray's state API on the cluster at
ADDRESS, printed as one JSON line: its nodes (id, IP address, state) and the sweep's
cell tasks (name, state, node id). Run in its own process so that the test process
never loads Ray's authentication token or connects to a cluster itself."""

import json
import sys

from ray.util.state import list_nodes, list_tasks

if __name__ == "__main__":
    address = sys.argv[1]
    nodes = [
        {"node_id": node.node_id, "node_ip": node.node_ip, "state": node.state}
        for node in list_nodes(address=address, raise_on_missing_output=False)
    ]
    tasks = [
        {"name": task.name, "state": task.state, "node_id": task.node_id}
        for task in list_tasks(
            address=address, filters=[("name", "=", "run_cell_on_ray")], raise_on_missing_output=False
        )
    ]
    print(json.dumps({"nodes": nodes, "tasks": tasks}))
