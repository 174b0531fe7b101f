#!/usr/bin/env bash
# Regenerate the lock files, each resolved fresh from pyproject.toml's ranges in a throw-away venv:
#   constraints.txt          the package and its test extras (the README's environment)
#   constraints-extras.txt   the same with the readers' extras [nastran,ansys] and EXUDYN (the peer code of the
#                            export test, never a dependency); pyNastran pins numpy < 2, so it is its own
#                            environment (.ci/run runs the readers' and EXUDYN's tests in it)
# Usage: bash scripts/lock.sh
set -euo pipefail
cd "$(dirname "$0")/.."
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
backend="$(sed -n 's/^requires = \["\(setuptools[^"]*\)"\]/\1/p' pyproject.toml)"
lock() {  # lock EXTRAS FILE [MORE PACKAGES]
  python3 -m venv "$tmp/$2.venv"
  "$tmp/$2.venv/bin/pip" install -q ".[$1]" "$backend" "${@:3}"
  {
    echo "# Exact versions of every dependency of ffrf-advisor with the extras [$1]${3:+ and $3} (Python 3.11)."
    echo "# Used as PIP_CONSTRAINT=$2 (README set-up, .ci/run), which also pins the build backend"
    echo "# (setuptools) in pip's isolated build environment."
    echo "# Regenerate with: bash scripts/lock.sh (pyproject.toml keeps the compatible ranges)."
    "$tmp/$2.venv/bin/pip" freeze --all --exclude ffrf-advisor --exclude pip | LC_ALL=C sort -f
  } > "$2"
  echo "wrote $2 ($(grep -vc '^#' "$2") packages)"
}
lock test,docs constraints.txt
lock test,nastran,ansys constraints-extras.txt exudyn
