#!/usr/bin/env bash
# Create .venv and install impeller-cam into it (with the dev extra when asked).
# Usage: scripts/setup.sh [--dev | --cadquery]
# --cadquery makes the second venv .venv-cadquery instead: impeller-cam with the
# cadquery extra and pytest (cadquery's OCP release cannot share a venv with
# build123d's: docs/dependencies.md).
# Also installs LinuxCNC's stand-alone interpreter (rs274, Debian package
# linuxcnc-uspace) and a headless browser (Debian package chromium) with --dev,
# since the tests feed our NC output to rs274 and open report.html in chromium.
set -euo pipefail
cd "$(dirname "$0")/.."
extra=""
if [ "${1:-}" = "--cadquery" ]; then
  if [ ! -x .venv-cadquery/bin/python ]; then
    python3 -m venv .venv-cadquery
    .venv-cadquery/bin/python -m pip install -q --upgrade pip
  fi
  exec .venv-cadquery/bin/python -m pip install -q -e ".[cadquery]" pytest
fi
if [ "${1:-}" = "--dev" ]; then
  extra="[dev]"
  if ! command -v rs274 >/dev/null 2>&1; then
    if [ "$(id -u)" = "0" ] && command -v apt-get >/dev/null 2>&1; then
      echo "installing linuxcnc-uspace (for rs274)" >&2
      apt-get update -qq
      DEBIAN_FRONTEND=noninteractive apt-get install -y -qq linuxcnc-uspace >/dev/null
    else
      echo "warning: rs274 not found; install Debian package linuxcnc-uspace" >&2
    fi
  fi
  if ! command -v chromium >/dev/null 2>&1; then
    if [ "$(id -u)" = "0" ] && command -v apt-get >/dev/null 2>&1; then
      echo "installing chromium (headless browser for the report test)" >&2
      apt-get update -qq
      DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null
    else
      echo "warning: chromium not found; install Debian package chromium" >&2
    fi
  fi
fi
if [ ! -x .venv/bin/python ]; then
  python3 -m venv .venv
  .venv/bin/python -m pip install -q --upgrade pip
fi
.venv/bin/python -m pip install -q -e ".${extra}"
