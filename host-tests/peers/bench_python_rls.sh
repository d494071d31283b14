#!/usr/bin/env bash
# The float64 RLS people would otherwise use, timed per sample on the same data as `sledid replay`:
# padasip's FilterRLS and sysidentpy's recursive least squares, in a virtual environment this script
# creates. Usage: host-tests/peers/bench_python_rls.sh [SAMPLES]
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
venv="${SLEDID_PEERS_VENV:-$here/../../target/peers-venv}"
if [ ! -x "$venv/bin/python" ]; then
  python3 -m venv "$venv"
  "$venv/bin/pip" install --quiet --disable-pip-version-check padasip==1.2.2 sysidentpy==0.9.0
fi
exec "$venv/bin/python" "$here/bench_python_rls.py" "${1:-20000}"
