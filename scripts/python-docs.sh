#!/usr/bin/env bash
# Builds the Python API reference from the package's docstrings with pdoc, into
# target/python-docs/ (ignored by git; open index.html). Needs the package and pdoc installed in
# the Python it runs ($PYTHON, default .venv/bin/python, which scripts/test.sh sets up). Fails on
# any pdoc warning (a name it cannot resolve, a module it cannot import), not only on errors.
set -euo pipefail
cd "$(dirname "$0")/.."
python="${PYTHON:-.venv/bin/python}"
out=target/python-docs
if ! "$python" -c "import pdoc, vadop" 2>/dev/null; then
  echo "error: $python needs pdoc and vadop: $python -m pip install pdoc ./" >&2
  exit 2
fi
rm -rf "$out"
"$python" -W error::UserWarning -m pdoc --docformat markdown --no-show-source --output-directory "$out" vadop vadop.plot vadop.viewer
for page in index.html vadop.html vadop/plot.html vadop/viewer.html; do
  if [ ! -s "$out/$page" ]; then
    echo "error: pdoc did not write $out/$page" >&2
    exit 1
  fi
done
echo "wrote $out/index.html"
