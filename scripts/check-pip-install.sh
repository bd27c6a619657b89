#!/bin/sh
# `pip install .` of the Python module into a fresh virtualenv that sees
# Debian's packages (numpy, pytest), then its tests against the installed
# copy (MR_CLI: the CLI whose results they must equal; default build/).
# Uses Debian's /usr/bin/python3 unless PYTHON is set.
set -eu
PYTHON=${PYTHON:-/usr/bin/python3}
MR_CLI=${MR_CLI:-$(pwd)/build/meshreduce}
venv=$(mktemp -d /tmp/meshreduce-venv.XXXXXX)
trap 'rm -rf "$venv"' EXIT
"$PYTHON" -m venv --system-site-packages "$venv"
"$venv/bin/pip" install --no-build-isolation --no-index -q .
cd /tmp
MR_CLI="$MR_CLI" "$venv/bin/python" -m pytest -q -p no:cacheprovider "$OLDPWD/python/tests"
