#!/usr/bin/env bash
# The Python module's packages from PyPI, pinned, in a virtual environment of Debian's python3 at
# .python-deps/ (not in build/, which a clean build removes): pybind11 2.13.6, the binding library
# the module is compiled with (Debian's 2.10.3 predates numpy 2 and returns wrong arrays under it,
# issue 26), and numpy 2 with pytest, under which the Python tests run a second time (ctest
# "python: … numpy 2"), and mypy, which checks the docs' examples against the module's type stub. Installs only what is missing; run by scripts/install-deps.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
venv=.python-deps
pins=("pybind11==2.13.6" "numpy==2.4.6" "pytest==8.3.5" "mypy==1.13.0")
if [ -x "$venv/bin/python" ] && "$venv/bin/python" - "${pins[@]}" <<'PY' 2>/dev/null; then
import sys
from importlib.metadata import version
sys.exit(any(version(p.split("==")[0]) != p.split("==")[1] for p in sys.argv[1:]))
PY
  echo "python-deps: ${pins[*]} present in $venv"
  exit 0
fi
rm -rf "$venv"
/usr/bin/python3 -m venv "$venv"
"$venv/bin/python" -m pip install -q --disable-pip-version-check "${pins[@]}"
echo "python-deps: installed ${pins[*]} into $venv"
