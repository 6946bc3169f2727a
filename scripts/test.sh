#!/usr/bin/env bash
# Set-up if needed, build, and run the default test suite (everything not labelled `stress`
# or `benchmark`). Extra arguments go to ctest. Fails, too, if the tests leave anything of
# theirs (flare*) in the temporary directory.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh --tests
scripts/build.sh
tmp="${TMPDIR:-/tmp}"
before=$(ls -A "$tmp" | sort)
ctest --test-dir build --output-on-failure --parallel "$(nproc)" --label-exclude "stress|benchmark" "$@"
left=$(comm -13 <(echo "$before") <(ls -A "$tmp" | sort) | grep '^flare' || true)
if [ -n "$left" ]; then
  echo "test.sh: the tests left these in $tmp:" $left >&2
  exit 1
fi
