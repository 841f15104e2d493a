#!/usr/bin/env bash
# The test suite against the newest and the oldest dependency versions pyproject.toml allows.
#
#   scripts/deps_check.sh [newest|oldest|both] [pytest arguments ...]
#
# Each kind gets a new virtual environment under ${DEPS_CHECK_DIR:-/tmp/euc-sim-deps}/KIND:
#   newest: pip install --upgrade -e ".[test]"  (whatever PyPI serves today within the bounds)
#   oldest: the same, constrained by scripts/constraints-oldest.txt (each lower bound pinned;
#           tests/test_deps_check.py holds the file to pyproject.toml's bounds)
# then runs `python -m pytest -q -n 2` (or the arguments given) from the repository root.
# Exit status: 0 when every kind passed, else the first failing kind's pytest status.
set -uo pipefail
cd "$(dirname "$0")/.."
kind=${1:-both}
[ $# -gt 0 ] && shift
case "$kind" in
  newest|oldest) kinds=("$kind") ;;
  both) kinds=(newest oldest) ;;
  *) echo "deps_check: the first argument is newest, oldest or both, not '$kind'" >&2; exit 2 ;;
esac
args=("$@")
[ ${#args[@]} -eq 0 ] && args=(-q -n 2)
root=${DEPS_CHECK_DIR:-/tmp/euc-sim-deps}
status=0
for k in "${kinds[@]}"; do
  venv="$root/$k"
  rm -rf "$venv"
  python3 -m venv "$venv" || { echo "deps_check: cannot create $venv" >&2; exit 2; }
  "$venv/bin/python" -m pip install --quiet --upgrade pip
  if [ "$k" = oldest ]; then
    "$venv/bin/python" -m pip install --quiet -c scripts/constraints-oldest.txt -e ".[test]" || exit 2
  else
    "$venv/bin/python" -m pip install --quiet --upgrade -e ".[test]" || exit 2
  fi
  echo "== $k: $("$venv/bin/python" -m pip list 2>/dev/null | grep -iE '^(numpy|scipy|mujoco|pandas|numba|control|matplotlib|dask) ' | tr -s ' ' | paste -sd ',' -)"
  "$venv/bin/python" -m pytest "${args[@]}"
  rc=$?
  echo "== $k: pytest exit $rc"
  [ $rc -ne 0 ] && [ $status -eq 0 ] && status=$rc
done
exit $status
