#!/usr/bin/env bash
# The main job: install, then the Case C distributed-vs-centralised comparison (bang-bang-off,
# 1800 s each, RK4 at 0.1 s) with its side-by-side MP4 (centralised | distributed), then the
# README's picture: the video's frame at the centralised run's end (scripts/readme_picture.py
# writes docs/_static/case_c_side_by_side.png; commit it when it changed).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup_env.sh
.venv/bin/python scripts/dist_vs_central.py --cases c --profiles bangbang --video --out runs/dist_vs_central "$@"
.venv/bin/python scripts/readme_picture.py --runs runs/dist_vs_central --out docs/_static/case_c_side_by_side.png
