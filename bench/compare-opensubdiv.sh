#!/usr/bin/env bash
# Side-by-side uniform refinement throughput: OpenSubdiv 3 `Far` (bench/opensubdiv/osd_refine.cpp,
# one thread, g++ -O2) against sylva's `refine` benchmark (crates/sylva/benches/refine.rs, one
# and two threads), on the same meshes in one run:
#   - Catmull–Clark: a 128×128 torus = 16,384 quads, levels 2 and 3;
#   - Loop: the same torus triangulated = 32,768 triangles, levels 2 and 3;
# positions + UVs (a seamed UV grid, linear face-varying interpolation) for both engines.
# Each engine's timing covers building the refiner from the mesh, refining the topology and
# the UV channel, and interpolating positions and UVs.
#
# Needs: g++, OpenSubdiv headers and libosdCPU (Debian/Ubuntu: apt-get install libosd-dev).
# Usage: bench/compare-opensubdiv.sh [RUNS]   (RUNS: OpenSubdiv repetitions, default 15)
# Numbers on a shared 2-core machine are noisy; run it on an idle machine.
set -euo pipefail
cd "$(dirname "$0")/.."
runs="${1:-15}"
work="target/compare-opensubdiv"
mkdir -p "$work"

echo "building bench/opensubdiv/osd_refine.cpp" >&2
g++ -O2 -std=c++14 bench/opensubdiv/osd_refine.cpp -losdCPU -o "$work/osd_refine"

# The benchmark torus (same formula and numbering as crates/sylva/benches/refine.rs).
torus() { # n m tris(0|1)
    awk -v n="$1" -v m="$2" -v tris="$3" 'BEGIN {
        tau = 6.283185307179586
        for (i = 0; i < n; i++) for (j = 0; j < m; j++) {
            a = i / n * tau; b = j / m * tau; r = 2 + 0.7 * cos(b)
            printf "v %.9g %.9g %.9g\n", r * cos(a), 0.7 * sin(b), r * sin(a)
        }
        for (i = 0; i <= n; i++) for (j = 0; j <= m; j++) printf "vt %.9g %.9g\n", i / n, j / m
        for (i = 0; i < n; i++) for (j = 0; j < m; j++) {
            A = (i % n) * m + (j % m) + 1;           B = (i % n) * m + ((j + 1) % m) + 1
            C = ((i + 1) % n) * m + ((j + 1) % m) + 1; D = ((i + 1) % n) * m + (j % m) + 1
            ta = i * (m + 1) + j + 1; tb = i * (m + 1) + j + 2
            tc = (i + 1) * (m + 1) + j + 2; td = (i + 1) * (m + 1) + j + 1
            if (tris) { printf "f %d/%d %d/%d %d/%d\nf %d/%d %d/%d %d/%d\n", A, ta, B, tb, C, tc, A, ta, C, tc, D, td }
            else      { printf "f %d/%d %d/%d %d/%d %d/%d\n", A, ta, B, tb, C, tc, D, td }
        }
    }'
}
torus 128 128 0 > "$work/torus-quads.obj"
torus 128 128 1 > "$work/torus-tris.obj"

declare -A osd
for level in 2 3; do
    osd["catmull-clark/level$level"]=$("$work/osd_refine" "$work/torus-quads.obj" catmark "$level" --time "$runs" | awk '{print $8}')
    osd["loop/level$level"]=$("$work/osd_refine" "$work/torus-tris.obj" loop "$level" --time "$runs" | awk '{print $8}')
done

echo "running cargo bench -p sylva --bench refine" >&2
cargo bench -q -p sylva --bench refine -- --noplot 2>/dev/null > "$work/sylva.txt"
# criterion: "refine/<case>/<threads>" then "thrpt:  [lo U mid U hi U]"; take mid in M faces/s.
declare -A ours
while read -r id value; do ours["$id"]="$value"; done < <(awk '
    /^refine\// { id = $1; sub(/^refine\//, "", id); fresh = 1 }
    /thrpt:/ && fresh { fresh = 0; v = $4; u = $5; if (u ~ /^K/) v /= 1000; else if (u ~ /^G/) v *= 1000; else if (u !~ /^M/) v /= 1e6
               print id, v }' "$work/sylva.txt")

printf "\n| mesh | level | output faces | OpenSubdiv 1 thread (M faces/s) | sylva 1 thread | ratio | sylva 2 threads | ratio |\n"
printf "|---|---|---|---|---|---|---|---|\n"
for case in catmull-clark loop; do
    for level in 2 3; do
        key="$case/level$level"
        o="${osd[$key]}"
        s1="${ours[$key/1thread]:-nan}"
        s2="${ours[$key/2thread]:-nan}"
        if [ "$case" = catmull-clark ]; then mesh="16,384 quads"; faces=$((65536 * 4 ** (level - 1))); else mesh="32,768 triangles"; faces=$((32768 * 4 ** level)); fi
        awk -v m="$mesh" -v l="$level" -v f="$faces" -v o="$o" -v a="$s1" -v b="$s2" 'BEGIN {
            printf "| %s | %d | %d | %.2f | %.2f | %.2f× | %.2f | %.2f× |\n", m, l, f, o, a, a / o, b, b / o }'
    done
done
