"""Environment overhead per concept: cost per simulated second through dm_control vs the plain run.

    .venv/bin/python scripts/bench_envs.py [--concepts cnusail msac ...] [--repeats 3]

Prints one JSON object (see :mod:`magsail_mj.envs.bench`).
"""

from magsail_mj.envs.bench import main

if __name__ == "__main__":
    main()
