#!/usr/bin/env bash
# Regenerate constraints.txt: the exact version of every dependency (package and test extras),
# resolved fresh from pyproject.toml's ranges in a throw-away venv. Usage: bash scripts/lock.sh
set -euo pipefail
cd "$(dirname "$0")/.."
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
python3 -m venv "$tmp/venv"
"$tmp/venv/bin/pip" install -q '.[test]' "$(sed -n 's/^requires = \["\(setuptools[^"]*\)"\]/\1/p' pyproject.toml)"
{
  echo "# Exact versions of every dependency of ffrf-advisor and its test extras (Python 3.11)."
  echo "# Used by the README's set-up commands and .ci/run as PIP_CONSTRAINT=constraints.txt, which"
  echo "# also pins the build backend (setuptools) in pip's isolated build environment."
  echo "# Regenerate with: bash scripts/lock.sh (pyproject.toml keeps the compatible ranges)."
  "$tmp/venv/bin/pip" freeze --all --exclude ffrf-advisor --exclude pip | LC_ALL=C sort -f
} > constraints.txt
echo "wrote constraints.txt ($(grep -vc '^#' constraints.txt) packages)"
