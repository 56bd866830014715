#!/usr/bin/env bash
# Creates .venv and installs msd-bench with its pinned dependencies.
# torch is installed first and by exact version so pip takes the local CPU
# wheel instead of resolving the multi-GB CUDA build.
set -euo pipefail
cd "$(dirname "$0")/.."
python3 -m venv .venv
.venv/bin/python -m pip install -q --upgrade pip
.venv/bin/python -m pip install -q "torch==2.13.0"
.venv/bin/python -m pip install -q -e ".[dev]"
.venv/bin/python -c "import rclpy, torch, numba, rosbags, mcap, control, gymnasium; print('environment ready')"
