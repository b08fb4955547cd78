#!/usr/bin/env bash
# The evaluation report: sets up, builds, then runs every evaluation and
# benchmark that README and doc/ cite (scripts/bench/report.py) and writes
# doc/evaluation.md and README's table of what to expect. The report itself
# takes about 3 minutes on a 2-core machine (2 of them the running head's
# cost), the build before it 5 from nothing. Options go to report.py
# (--quick: a check of the script).
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
bash "$here/scripts/setup.sh"
bash "$here/scripts/build.sh"
export PATH="/usr/bin:$PATH"
ws="${TLP_WS:-$here/build_ws}"
set +u; source "$ws/install/setup.bash"; set -u
python3 "$here/scripts/bench/report.py" --ws "$ws" "$@"
