"""Plan the test problems on a running Ray cluster and in this process; write both record lists as JSON.

Usage: ``python ray_client.py ADDRESS PROBLEM_PATH...``; writes ``$ROS2_TEST_OUT/results.json`` (the session
helper's output folder). Waits up to 120 s for the cluster's head to accept the connection.
"""

from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path


def main(address: str, paths: list[str]) -> None:
    import ray

    from pfield.batch import plan_many
    from pfield.scene import read_problems

    deadline = time.monotonic() + 120.0
    while True:
        try:
            ray.init(address=address, log_to_driver=False,
                     runtime_env={"env_vars": {"PYTHONPATH": os.environ.get("PYTHONPATH", "")}})
            break
        except (ConnectionError, RuntimeError):
            if time.monotonic() > deadline:
                raise
            time.sleep(1.0)
    problems = read_problems(paths)
    on_ray = list(plan_many(problems, workers=2, backend="ray", address=address))
    ray.shutdown()
    here = list(plan_many(problems, workers=1))
    Path(os.environ["ROS2_TEST_OUT"], "results.json").write_text(json.dumps({"ray": on_ray, "process": here}))


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2:])
