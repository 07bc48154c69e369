#!/usr/bin/env bash
# Create the peer's own environment (benchmarks/.venv-pykep) with ESA pykep 3.0.1.
# pykep is NOT a runtime dependency of spaceopt; it is only used by benchmarks/peer_pykep_run.py.
#
# Packaging problem: the pykep 3.0.1 wheel lacks the TOPS data files that pykep.trajopt.gym
# reads at import time, so `import pykep` raises FileNotFoundError. We write empty placeholder
# files at the paths the package expects (inside this venv only; nothing of pykep is committed).
# The placeholders are created by peer_pykep_run.ensure_placeholders(), also before every run.
set -euo pipefail
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
VENV="$HERE/.venv-pykep"
PY="${PYTHON:-python3}"
if [ ! -x "$VENV/bin/python" ]; then
  "$PY" -m venv "$VENV"
fi
"$VENV/bin/pip" install --quiet --upgrade pip
# versions as resolved on 2026-11-22 (pykep 3.0.1 pulls heyoka 7.10.1 and pygmo 2.20.0)
"$VENV/bin/pip" install --quiet "pykep==3.0.1" "heyoka==7.10.1" "pygmo==2.20.0" "numpy==2.4.6" "scipy==1.17.1"
"$VENV/bin/python" "$HERE/peer_pykep_run.py" --placeholders-only
"$VENV/bin/python" -c "import pykep; print('pykep', pykep.__version__)"
