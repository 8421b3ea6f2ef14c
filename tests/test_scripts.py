"""Reports written by the reproduction scripts follow the project's rules."""

from __future__ import annotations


from tests.conftest import load_file_module


def _script(name: str):
    return load_file_module("scripts", name)


def test_a_failed_structure_is_never_put_into_a_ratio():
    table = _script("dist_vs_central").comparison_table
    failed = {
        "case_c_central_bangbang": {"status": "structure_failed", "surface_sd_max_m": 1.29},
        "case_c_distributed_bangbang": {"status": "completed", "surface_sd_max_m": 0.44},
    }
    assert table(failed).splitlines()[-1] == "| C | bangbang | no ratio: central structure_failed |"
    both = {
        "case_a_central_bangbang": {"status": "completed", "surface_sd_max_m": 1.29},
        "case_a_distributed_bangbang": {"status": "completed", "surface_sd_max_m": 0.43},
    }
    assert table(both).splitlines()[-1] == "| A | bangbang | 3 |"
