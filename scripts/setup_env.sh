#!/usr/bin/env bash
# Builds the project's environment for one ROS 2 distribution and records it as the one
# the launch scripts re-execute into (msd_bench/_bootstrap.py reads .msd-env).
#
#   bash scripts/setup_env.sh [kilted|jazzy|system]     (make setup DISTRO=...)
#
#   kilted  .venv         ROS 2 Kilted from PyPI wheels (the default)
#   jazzy   .venv-jazzy   ROS 2 Jazzy LTS from PyPI wheels
#   system  .venv-system  no ROS wheels: a venv with --system-site-packages that sees the
#                         ROS 2 of the shell it is built in (source /opt/ros/<distro>/setup.bash)
#
# torch is installed first and by exact version so pip takes the local CPU wheel
# instead of resolving the multi-GB CUDA build.
set -euo pipefail
cd "$(dirname "$0")/.."
distro="${1:-kilted}"
case "$distro" in
    kilted) venv=.venv; extras="dev,kilted"; venv_opts=(); ros="Kilted, PyPI wheels" ;;
    jazzy) venv=.venv-jazzy; extras="dev,jazzy"; venv_opts=(); ros="Jazzy, PyPI wheels" ;;
    system)
        venv=.venv-system; extras="dev"; venv_opts=(--system-site-packages); ros="${ROS_DISTRO:-}, sourced"
        if [ -z "${ROS_DISTRO:-}" ]; then
            echo "setup_env.sh: DISTRO=system needs a sourced ROS 2 (source /opt/ros/<distro>/setup.bash first)" >&2
            exit 2
        fi ;;
    *)
        echo "setup_env.sh: unknown DISTRO '$distro' (kilted, jazzy or system)" >&2
        exit 2 ;;
esac
python3 -m venv "${venv_opts[@]}" "$venv"
"$venv/bin/python" -m pip install -q --upgrade pip
"$venv/bin/python" -m pip install -q "torch==2.13.0"
"$venv/bin/python" -m pip install -q -e ".[$extras]"
"$venv/bin/python" -c "import rclpy, torch, numba, rosbags, mcap, control, gymnasium; print('environment ready')" || {
    echo "setup_env.sh: $venv cannot import rclpy and the project's dependencies (for DISTRO=system: is ROS 2 sourced in this shell?)" >&2
    exit 1
}
echo "$venv" > .msd-env
echo "$venv is the project's environment (ROS 2 $ros); launch scripts re-execute into it"
