#!/usr/bin/env bash
# Regenerate the lock files, each resolved fresh from pyproject.toml's ranges in a throw-away venv:
#   constraints.txt          the package and its test extras (the README's environment)
#   constraints-nastran.txt  the same with the [nastran] extra (pyNastran pins numpy < 2, so it is its own
#                            environment; .ci/run runs the Nastran tests in it)
# Usage: bash scripts/lock.sh
set -euo pipefail
cd "$(dirname "$0")/.."
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
backend="$(sed -n 's/^requires = \["\(setuptools[^"]*\)"\]/\1/p' pyproject.toml)"
lock() {  # lock EXTRAS FILE
  python3 -m venv "$tmp/$2.venv"
  "$tmp/$2.venv/bin/pip" install -q ".[$1]" "$backend"
  {
    echo "# Exact versions of every dependency of ffrf-advisor with the extras [$1] (Python 3.11)."
    echo "# Used as PIP_CONSTRAINT=$2 (README set-up, .ci/run), which also pins the build backend"
    echo "# (setuptools) in pip's isolated build environment."
    echo "# Regenerate with: bash scripts/lock.sh (pyproject.toml keeps the compatible ranges)."
    "$tmp/$2.venv/bin/pip" freeze --all --exclude ffrf-advisor --exclude pip | LC_ALL=C sort -f
  } > "$2"
  echo "wrote $2 ($(grep -vc '^#' "$2") packages)"
}
lock test constraints.txt
lock test,nastran constraints-nastran.txt
