#!/usr/bin/env bash
# Fails when README's table of what to expect is not the one in the generated
# report (doc/evaluation.md): a figure changes by running scripts/report.sh,
# never by editing README.
set -euo pipefail
here="$(cd "$(dirname "$0")/../.." && pwd)"
readme=$(sed -n '/report:summary begin/,/report:summary end/p' "$here/README.md" | grep '^|' || true)
report=$(sed -n '/^## What to expect/,/^## /p' "$here/doc/evaluation.md" | grep '^|' || true)
if [ -z "$readme" ] || [ "$readme" != "$report" ]; then
  echo "check_report: README's table of what to expect differs from doc/evaluation.md's: run scripts/report.sh"
  diff <(echo "$readme") <(echo "$report") || true
  exit 1
fi
echo "check_report: README's table of what to expect is the report's ($(echo "$readme" | wc -l) lines)"
