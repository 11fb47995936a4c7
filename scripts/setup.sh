#!/usr/bin/env bash
# Sets up a machine for millscope: system libraries (apt-get), then a .venv with millscope installed.
#   bash scripts/setup.sh          the package and its runtime dependencies
#   bash scripts/setup.sh --test   the same, plus the test dependencies
# Safe to run again: installed system packages are not fetched twice.
set -euo pipefail
cd "$(dirname "$0")/.."

extras=""
[ "${1:-}" = "--test" ] && extras="[test]"

system_packages=(g++ cmake pkg-config libeigen3-dev libfftw3-dev libhwy-dev)
missing=()
for p in "${system_packages[@]}"; do
  dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing system packages: ${missing[*]}"
  sudo=""
  [ "$(id -u)" -ne 0 ] && sudo="sudo"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq "${missing[@]}" >/dev/null
fi

python=${PYTHON:-python3}
[ -x .venv/bin/python ] || "$python" -m venv .venv
.venv/bin/python -m pip install -q --upgrade pip
echo "setup: building and installing millscope$extras into .venv"
.venv/bin/python -m pip install -q ".$extras"
