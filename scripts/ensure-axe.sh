#!/usr/bin/env bash
# Installs axe-core (the accessibility engine the browser tests run inside the page) from npm
# into build/npm if it is missing.  Pinned: a new axe-core may add rules.  Never a CDN: the
# tests inject this local file.
set -euo pipefail
AXE_VERSION="4.14.1"
DEST="build/npm"
FILE="$DEST/node_modules/axe-core/axe.min.js"
cd "$(dirname "$0")/.."
if [ -f "$FILE" ] && grep -q "\"version\": \"$AXE_VERSION\"" "$DEST/node_modules/axe-core/package.json"; then
  exit 0
fi
if ! command -v npm >/dev/null 2>&1; then
  SUDO=""
  if [ "$(id -u)" != "0" ]; then SUDO="sudo"; fi
  echo "Installing Debian's npm for axe-core..."
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq npm >/dev/null
fi
echo "Installing axe-core $AXE_VERSION from npm into $DEST..."
mkdir -p "$DEST"
npm install --prefix "$DEST" --no-save --no-audit --no-fund --loglevel=error "axe-core@$AXE_VERSION" >/dev/null
test -f "$FILE"
