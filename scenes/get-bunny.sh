#!/bin/sh
# get-bunny.sh: fetches the Stanford bunny from the npm package bunny@1.0.1
# and writes it as a Wavefront OBJ file.
#
# Usage: sh scenes/get-bunny.sh OUT.obj
#
# The mesh is not committed to the repository; `make` runs this script to
# produce scenes/meshes/bunny.obj.  The package tarball is checked against a
# pinned SHA-256 so that every machine renders exactly the same mesh.  The
# OBJ is written to OUT.obj.tmp and renamed at the end, so an interrupted
# run never leaves a partial OUT.obj behind.
set -eu

PKG=bunny
VERSION=1.0.1
TARBALL_SHA256=381e02c74b98cf18814d7bec794726ef70b9c67e037273e82054d0043f6ae303

me=get-bunny.sh

die() {
    echo "$me: $*" >&2
    exit 1
}

[ $# -eq 1 ] || die "usage: sh scenes/get-bunny.sh OUT.obj"
out=$1

# The converter lives beside this script, wherever it is run from.
here=$(cd "$(dirname "$0")" && pwd)
converter=$here/bunny-to-obj.js
[ -f "$converter" ] || die "cannot find $converter"

command -v npm >/dev/null 2>&1 ||
    die "npm is not installed (Debian: apt-get install npm)"
command -v node >/dev/null 2>&1 ||
    die "node is not installed (Debian: apt-get install nodejs)"
command -v tar >/dev/null 2>&1 || die "tar is not installed"

tmp=$(mktemp -d "${TMPDIR:-/tmp}/lensray-bunny.XXXXXX") ||
    die "cannot create a temporary directory"
# Clean up on every exit, including Ctrl-C: the temporary directory and a
# half-written OBJ, never a finished one.
cleanup() {
    rm -rf "$tmp"
    rm -f "$out.tmp"
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM

echo "$me: downloading $PKG@$VERSION with npm"
if ! (cd "$tmp" && npm pack --loglevel=error "$PKG@$VERSION" >npm-pack.log 2>&1); then
    cat "$tmp/npm-pack.log" >&2 || true
    die "could not download $PKG@$VERSION from the npm registry (is it reachable?)"
fi
tarball=$tmp/$PKG-$VERSION.tgz
[ -f "$tarball" ] || die "npm pack did not produce $PKG-$VERSION.tgz"

if command -v sha256sum >/dev/null 2>&1; then
    sum=$(sha256sum "$tarball" | cut -d ' ' -f 1)
    [ "$sum" = "$TARBALL_SHA256" ] ||
        die "$PKG-$VERSION.tgz has SHA-256 $sum, expected $TARBALL_SHA256"
else
    echo "$me: sha256sum not found; skipping the checksum test" >&2
fi

mkdir "$tmp/x"
tar -xzf "$tarball" -C "$tmp/x" || die "cannot extract $tarball"
[ -f "$tmp/x/package/index.js" ] ||
    die "$PKG-$VERSION.tgz does not contain package/index.js"

outdir=$(dirname "$out")
mkdir -p "$outdir" || die "cannot create $outdir"
node "$converter" "$tmp/x/package" "$out" ||
    die "converting the bunny to OBJ failed"
[ -s "$out" ] || die "$out was not written"
