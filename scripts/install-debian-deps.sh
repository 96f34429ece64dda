#!/usr/bin/env bash
# Debian packages the tests need: the AVR toolchain, Debian's Arduino core and simavr (firmware tests),
# and hdf5-tools (h5dump 1.10: every HDF5 file bootnav writes must be readable by HDF5 1.10 tools).
# chromium + chromium-driver: tests/test_html.py loads path.html in a real headless browser.
# Idempotent: installs only what is missing. Needs root (CI runs as root) or sudo.
set -euo pipefail
PKGS=(gcc-avr avr-libc arduino-core-avr simavr libsimavr-dev pkg-config hdf5-tools chromium chromium-driver)
missing=()
for p in "${PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0
echo "installing Debian packages: ${missing[*]}"
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -q
$SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
