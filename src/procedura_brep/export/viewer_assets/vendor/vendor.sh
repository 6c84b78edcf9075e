#!/bin/sh
# Rebuild ../three.min.js (and ../LICENSE-three) from the npm registry at the pinned version.
# Needs node and npm; writes nothing outside this folder but a temporary directory.
set -eu
THREE_VERSION=0.187.0
ESBUILD_VERSION=0.25.0
here=$(cd "$(dirname "$0")" && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cd "$tmp"
npm init -y >/dev/null
npm install --no-audit --no-fund --silent "three@$THREE_VERSION" "esbuild@$ESBUILD_VERSION"
cp "$here/entry.js" entry.js
./node_modules/.bin/esbuild entry.js --bundle --minify --format=iife --global-name=THREE \
  --legal-comments=eof --target=es2020 \
  --banner:js="/* three.js $THREE_VERSION (MIT, see LICENSE-three), OrbitControls and RoomEnvironment, bundled by esbuild $ESBUILD_VERSION from entry.js */" \
  --outfile="$here/../three.min.js"
cp node_modules/three/LICENSE "$here/../LICENSE-three"
