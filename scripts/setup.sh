#!/usr/bin/env bash
# Set up holecli in ./.venv on a fresh Debian machine: the system library open3d needs (libusb-1.0),
# a virtual environment, and the project with its test extra. Safe to run again: it only does what is
# missing.
set -euo pipefail
cd "$(dirname "$0")/.."

python=${PYTHON:-python3}

have_libusb() {
    ldconfig -p 2>/dev/null | grep -q 'libusb-1\.0\.so\.0' || compgen -G '/usr/lib/*/libusb-1.0.so.0' >/dev/null
}

if ! have_libusb; then
    echo "setup: installing the Debian package libusb-1.0-0 (open3d needs it)" >&2
    if [ "$(id -u)" -eq 0 ]; then sudo=""; elif command -v sudo >/dev/null; then sudo="sudo"; else
        echo "setup: libusb-1.0 is missing and I am not root: run 'apt-get install libusb-1.0-0' as root" >&2
        exit 1
    fi
    export DEBIAN_FRONTEND=noninteractive
    $sudo apt-get install -y -qq libusb-1.0-0 >/dev/null 2>&1 \
        || { $sudo apt-get update -qq && $sudo apt-get install -y -qq libusb-1.0-0 >/dev/null; }
fi

if [ ! -x .venv/bin/python ]; then
    echo "setup: creating .venv" >&2
    "$python" -m venv .venv
fi
if [ ! -x .venv/bin/holecli ] || ! .venv/bin/python -c "import open3d, pytest, jsonschema" >/dev/null 2>&1; then
    echo "setup: installing holecli and its dependencies into .venv" >&2
    # (pip's notes about local package indexes that this machine lacks are noise: filtered out)
    .venv/bin/python -m pip install --quiet -e '.[test]' 2> >(grep -v 'is ignored: it is neither a file nor a directory' >&2)
fi
