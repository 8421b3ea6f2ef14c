"""``python -m magsail_mj.sweep``: the run process of a sweep (started by :func:`magsail_mj.sweep.runner.supervise`)."""

from magsail_mj.sweep.runner import process_main

if __name__ == "__main__":
    process_main()
