#!/usr/bin/env bash
# `pip wheel .` and `pip install` of that wheel into a fresh virtual environment (issue 26), as a
# user would after scripts/install-deps.sh: the same CMake build through scikit-build-core
# (pyproject.toml). Then the installed module and command are checked: sombra.__version__ is what
# `sombra --version` prints, and the Python tests pass against the installed module (not the build
# tree's). Needs PyPI (scikit-build-core, pybind11, numpy, pytest). 90 s on 2 cores (pyproject.toml builds
# the wheel as a unity build; file by file the check took 291 s).
set -euo pipefail
cd "$(dirname "$0")/.."
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
/usr/bin/python3 -m venv "$work/venv"
"$work/venv/bin/pip" install -q --disable-pip-version-check "pytest==8.3.5"
"$work/venv/bin/pip" wheel -q --disable-pip-version-check . -w "$work/dist"
wheel=$(ls "$work"/dist/sombra_shadows-*.whl)
echo "pip-check: built $(basename "$wheel")"
"$work/venv/bin/pip" install -q --disable-pip-version-check "$wheel"
module_version=$(cd "$work" && venv/bin/python -c "import sombra; print(sombra.__version__)")
command_version=$("$work/venv/bin/sombra" --version)
if [ "sombra $module_version" != "$command_version" ]; then
  echo "pip-check: sombra.__version__ $module_version but \`sombra --version\` says '$command_version'" >&2
  exit 1
fi
where=$(cd "$work" && venv/bin/python -c "import sombra; print(sombra.__file__)")
case "$where" in "$work"/venv/*) ;; *) echo "pip-check: the module came from $where, not the venv" >&2; exit 1 ;; esac
echo "pip-check: module $where, command $command_version"
ls "$work"/venv/lib/python3*/site-packages/sombra-stubs/__init__.pyi >/dev/null  # the type stub (PEP 561)
(cd "$work" && SOMBRA_SOURCE_DIR="$OLDPWD" PATH="$work/venv/bin:/usr/local/bin:/usr/bin:/bin" \
   venv/bin/python -m pytest -q -p no:cacheprovider "$OLDPWD/python/tests")
echo "pip-check: passed"
