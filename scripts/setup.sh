#!/usr/bin/env bash
# Set up holecli in ./.venv on a fresh Debian machine: the system libraries it needs (libusb-1.0 for
# open3d; the venv module where Debian ships it apart), a Python that open3d has a wheel for, a virtual
# environment, and the project with its test extra, the extras of the optional formats (e57, las), of
# the pictures (plot, matplotlib), of the documentation site (docs, MkDocs and its Material theme) and
# of the service (serve, postgres, opcua: FastAPI, uvicorn, psycopg, asyncua) and of batch --cluster
# (cluster: Dask), so that their readers, holecli plot, the docs' build, holecli serve and the cluster
# batch are tested; and Debian's postgresql, which the tests of the PostgreSQL results store start,
# and chromium, in which the tests render holecli report's HTML.
# Safe to run again: it only does what is missing.
#
# The Python: $PYTHON if set, else python3 when open3d has a wheel for it (open3d 0.20: CPython 3.10 to
# 3.14, so Debian 12's 3.11 and Debian 13's 3.13), else python3.13, python3.12 or python3.11 from PATH,
# else a Python 3.12 that uv (installed from PyPI into .venv-uv) downloads. uv's interpreters come
# from GitHub (python-build-standalone), not from PyPI: a machine that reaches only the package
# registries cannot take that last step.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD

say() { echo "setup: $*" >&2; }

if [ "$(id -u)" -eq 0 ]; then sudo=""; elif command -v sudo >/dev/null; then sudo="sudo"; else sudo="none"; fi
apt_install() {  # apt_install PACKAGE...: install Debian packages (root or sudo), updating the lists once if need be
    if [ "$sudo" = none ]; then
        say "I am not root and have no sudo: run 'apt-get install $*' as root"
        exit 1
    fi
    export DEBIAN_FRONTEND=noninteractive
    $sudo apt-get install -y -qq "$@" >/dev/null 2>&1 \
        || { $sudo apt-get update -qq && $sudo apt-get install -y -qq "$@" >/dev/null; }
}

have_libusb() {
    ldconfig -p 2>/dev/null | grep -q 'libusb-1\.0\.so\.0' || compgen -G '/usr/lib/*/libusb-1.0.so.0' >/dev/null
}
if ! have_libusb; then
    say "installing the Debian package libusb-1.0-0 (open3d needs it)"
    apt_install libusb-1.0-0
fi
# PostgreSQL: the test suite starts a throwaway server of Debian's package to test the results store
# (holecli serve --store postgresql://..., tests/store/); holecli itself needs it only for that store
have_postgres() { compgen -G '/usr/lib/postgresql/*/bin/initdb' >/dev/null; }
if ! have_postgres; then
    say "installing the Debian package postgresql (the tests of the PostgreSQL results store start one)"
    apt_install postgresql
fi

# Chromium: the test suite renders holecli report's HTML in a real browser (headless), to check that it
# draws, holds its tables and charts and logs no error; holecli itself never needs it
have_chromium() { command -v chromium >/dev/null; }
if ! have_chromium; then
    say "installing the Debian package chromium (the tests of holecli report render its HTML in it)"
    apt_install chromium
fi

# pip's notes about local package indexes that this machine lacks are noise: filtered out
pip_quiet() { "$@" 2> >(grep -v 'is ignored: it is neither a file nor a directory' >&2); }

# open3d_wheel PYTHON: does PyPI have an open3d build for this interpreter (and is it new enough)?
# Only pip's "no matching distribution" counts as no: another failure (no network) is left to pip install.
open3d_wheel() {
    "$1" -c 'import sys; sys.exit(sys.version_info < (3, 11))' 2>/dev/null || return 1
    local dist=open3d version answer
    if "$1" -c 'import platform, sys; sys.exit(not (sys.platform == "linux" and platform.machine() == "x86_64"))'; then
        dist=open3d-cpu
    fi
    version=$("$1" -c 'import sys; print("%d.%d" % sys.version_info[:2])')
    # ask with the venv's pip when the interpreter has none (Debian's python3 without python3-pip)
    local pip=("$1" -m pip)
    "$1" -m pip --version >/dev/null 2>&1 || pip=(.venv/bin/python -m pip)
    answer=$("${pip[@]}" index versions "$dist" --python-version "$version" --only-binary=:all: 2>&1) && return 0
    ! grep -q 'No matching distribution' <<<"$answer"
}

make_venv() {  # make_venv PYTHON: create .venv with it (Debian's python3 may need python3.X-venv for that)
    if ! "$1" -m venv .venv >/dev/null 2>&1; then
        rm -rf .venv
        local venv_pkg
        venv_pkg="python$("$1" -c 'import sys; print("%d.%d" % sys.version_info[:2])')-venv"
        say "installing the Debian package $venv_pkg ($1 -m venv needs it)"
        apt_install "$venv_pkg"
        "$1" -m venv .venv
    fi
}

if [ ! -x .venv/bin/python ]; then
    python=${PYTHON:-python3}
    say "creating .venv with $python ($("$python" --version 2>&1))"
    make_venv "$python"
    if [ -z "${PYTHON:-}" ] && ! open3d_wheel .venv/bin/python; then
        say "$python ($("$python" --version 2>&1)) is older than 3.11 or has no open3d wheel on PyPI"
        found=""
        for candidate in python3.13 python3.12 python3.11; do
            if command -v "$candidate" >/dev/null && open3d_wheel "$candidate"; then found=$candidate; break; fi
        done
        if [ -z "$found" ]; then
            say "no python3.13, python3.12 or python3.11 with an open3d wheel is on PATH: asking uv for Python 3.12"
            [ -x .venv-uv/bin/uv ] || { "$python" -m venv .venv-uv && pip_quiet .venv-uv/bin/python -m pip install --quiet uv; }
            .venv-uv/bin/uv python find 3.12 >/dev/null 2>&1 || .venv-uv/bin/uv python install 3.12 || {
                say "uv could not download Python 3.12 (it comes from GitHub, not from PyPI);"
                say "install Python 3.11 to 3.14 (e.g. 'apt-get install python3.11-venv' where Debian has it) and run: PYTHON=python3.11 $0"
                rm -rf .venv
                exit 1
            }
            found=$(.venv-uv/bin/uv python find 3.12)
        fi
        say "holecli needs Python 3.11 or newer, and open3d a wheel for it: using $found ($("$found" --version 2>&1)) instead"
        rm -rf .venv
        make_venv "$found"
    fi
fi

# holecli is installed editable by path (editable_mode=compat: a .pth file puts this folder on sys.path).
# setuptools' default editable finder is consulted only after sys.path, so from the folder that holds a
# clone named holecli/, `import holecli` found the clone as an empty namespace package.
installed() {  # run from / so that the current folder is not what finds holecli
    (cd / && "$root/.venv/bin/python" - "$root" <<'EOF' >/dev/null 2>&1
import os, sys
import open3d, pytest, jsonschema, pye57, laspy, lazrs, matplotlib, mkdocs, material  # noqa: F401
import fastapi, uvicorn, prometheus_client, psycopg, asyncua, httpx, schemathesis  # noqa: F401
import distributed  # noqa: F401
import holecli
root = os.path.realpath(sys.argv[1])
sys.exit(os.path.realpath(holecli.__file__) != os.path.join(root, "holecli", "__init__.py")
         or root not in {os.path.realpath(p) for p in sys.path if p})
EOF
    )
}
if [ ! -x .venv/bin/holecli ] || ! installed; then
    say "installing holecli and its dependencies into .venv"
    # a .venv made before holecli took open3d-cpu has the full open3d (with CUDA): both install the
    # package open3d/, so the old one goes first
    if .venv/bin/python -c 'import platform, sys; sys.exit(not (sys.platform == "linux" and platform.machine() == "x86_64"))' \
        && .venv/bin/python -m pip show open3d >/dev/null 2>&1; then
        say "replacing open3d with open3d-cpu in .venv"
        pip_quiet .venv/bin/python -m pip uninstall --quiet --yes open3d
    fi
    pip_quiet .venv/bin/python -m pip install --quiet -e '.[test,e57,las,plot,docs,serve,postgres,opcua,cluster]' --config-settings editable_mode=compat
fi
