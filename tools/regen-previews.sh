#!/usr/bin/env bash
# Regenerates the preset catalogue pictures: docs/presets/<preset>.png for every grown
# preset (320 px, default mesher) and docs/curves/<preset>.png (480 px) for every curves preset.
# Usage: tools/regen-previews.sh            (from the repository root; release build)
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -p sylva-cli
bin=target/release/sylva
out=docs/presets
mkdir -p "$out" docs/curves
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
"$bin" presets | while read -r name _; do
    case "$name" in
    curves-*) ;; # below: the curves test writes them with the best PNG compression
    *) "$bin" grow "$name" -o "$tmp/$name.glb" --preview "$out/$name.png" --set output.preview_size=320 >/dev/null ;;
    esac
    echo "$name"
done
cargo test -p sylva --release --test curves -- --ignored regenerate_docs_pngs --nocapture
