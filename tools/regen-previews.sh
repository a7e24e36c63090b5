#!/usr/bin/env bash
# Regenerates the preset catalogue pictures: docs/presets/<preset>.png for every grown
# preset (320 px, default mesher), docs/curves/<preset>.png (480 px) for every curves
# preset, docs/meshers/<tree>-<mesher>.png: two trees with each mesher, and
# docs/cpfg/*.png: three cpfg corpus models (open L-systems, sub-L-systems).
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
# The same tree with every mesher (docs/meshers.md), each refined as its seed says.
mkdir -p docs/meshers
for m in "tube none 0" "hull loop 2" "sweep loop 2" "quad catmull-clark 2"; do
    set -- $m
    for tree in lsys-ternary-tree lsys-honda-a; do
        "$bin" grow "$tree" -o "$tmp/$tree-$1.glb" --preview "docs/meshers/$tree-$1.png" --preview-size 480 \
            --set mesh.method="$1" --set refine.scheme="$2" --set refine.levels="$3" >/dev/null
    done
done
# cpfg corpus models (docs/cpfg-compatibility.md), when the corpus is next to the repo.
corpus=../shared/corpus/cpfg
if [ -d "$corpus" ]; then
    mkdir -p docs/cpfg
    # The environmental programs come from the models' own .e and spec files.
    "$bin" grow "$corpus/11-CPFG__07-Open__04-sierpinski-random/fractal.l" -o "$tmp/s.glb" \
        --preview docs/cpfg/sierpinski-random.png --preview-size 320 >/dev/null
    "$bin" grow "$corpus/11-CPFG__07-Open__06-canalization/plant.l" -o "$tmp/c.glb" \
        --preview docs/cpfg/canalization.png --preview-size 320 >/dev/null
    "$bin" grow "$corpus/10-manuals__11-CPFG__Sedge/sedge.l" -o "$tmp/e.glb" --preview docs/cpfg/sedge.png \
        --preview-size 320 >/dev/null
    # A generalized cylinder with an @# contour (the lily leaf).
    "$bin" grow "$corpus/11-CPFG__03-inverse-modeling__01-herb-lily/plant.l" -o "$tmp/l.glb" \
        --preview docs/cpfg/herb-lily.png --preview-size 320 >/dev/null
fi
# Seed 001's leaf mode on a compound leaf string (docs/meshers.md).
"$bin" grow crates/sylva/tests/data/compound-leaf.str --set mesh.method=leaf --set refine.levels=2 \
    -o "$tmp/leaf.glb" --preview docs/meshers/compound-leaf-leaf.png --preview-size 320 >/dev/null
