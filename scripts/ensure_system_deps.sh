#!/usr/bin/env bash
# Debian packages the project needs, installed when missing (root or sudo):
#  * libusb-1.0-0: Open3D's import needs it (required: the set-up fails without it);
#  * chromium: the headless browser the report test opens report.html in (optional: when it cannot be
#    installed the set-up goes on and that test skips, saying why).
set -euo pipefail
SUDO=""
if [ "$(id -u)" != "0" ]; then SUDO="sudo"; fi
updated=""
apt_install() {
  if [ -z "$updated" ]; then
    $SUDO apt-get update -qq >/dev/null || true
    updated=1
  fi
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "$@" >/dev/null
}
if ! ldconfig -p 2>/dev/null | grep -q 'libusb-1.0.so.0'; then
  echo "installing libusb-1.0-0 (needed by Open3D)" >&2
  apt_install libusb-1.0-0
fi
if ! command -v chromium >/dev/null 2>&1; then
  echo "installing chromium (headless browser for the report test; optional)" >&2
  apt_install chromium || echo "chromium could not be installed: the report's browser test will skip" >&2
fi
