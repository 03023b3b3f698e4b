#!/usr/bin/env bash
# Debian's headless Chromium and its WebDriver for `make docs-check`, when they are missing.
# Needs root and apt (this machine, CI, the Docker image); elsewhere it says what to install.
set -euo pipefail
if command -v chromium >/dev/null && command -v chromedriver >/dev/null; then exit 0; fi
if [[ $(id -u) -ne 0 ]] || ! command -v apt-get >/dev/null; then
  echo "docs-check: install Debian's chromium and chromium-driver (apt), then run again" >&2
  exit 1
fi
echo "docs-check: installing chromium and chromium-driver with apt"
export DEBIAN_FRONTEND=noninteractive
apt-get update -q >/dev/null
apt-get install -y -q --no-install-recommends chromium chromium-driver >/dev/null
