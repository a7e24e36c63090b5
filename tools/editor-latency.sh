#!/usr/bin/env bash
# The editor's latency figures (docs/editor.md, BENCHMARKS.md "Editor latency"): opens
# `sylva edit` on a preset in a real window under Xvfb (Mesa's lavapipe draws), applies
# a leaf, a wind and a generator change one at a time once each tree is shown, closes,
# and summarises the editor's own frame log.
#   tools/editor-latency.sh [PRESET]     (needs: cargo build --release -p sylva-cli; xvfb-run)
set -euo pipefail
cd "$(dirname "$0")/.."
preset="${1:-wp-quaking-aspen}"
log="$(mktemp -d)/frames.jsonl"
xvfb-run -a -s "-screen 0 1280x800x24" target/release/sylva edit "$preset" \
  --frame-log "$log" --close-after-tree 5 \
  --script-set leaves.alpha_cutoff=0.6 \
  --script-set wind.preset=breeze \
  --script-set seed=7
python3 - "$log" <<'PY'
import json, sys
rows = [json.loads(l) for l in open(sys.argv[1])]
edits, shown, frames = [], [], []
last_edit = "launch"
for r in rows:
    if "event" in r and r["event"] == "edit":
        last_edit = r["about"]
    elif "tree_shown" in r:
        shown.append((last_edit, r["tree_shown"], r["latency_ms"], r["grow_ms"], r.get("stages_ms", {})))
    elif "frame" in r:
        frames.append(r)
print(f"launch to first tree: {shown[0][1]:.0f} ms (grow {shown[0][3]:.0f} ms)")
for what, at, lat, grow, stages in shown[1:]:
    times = ", ".join(f"{k} {v:.0f}" for k, v in stages.items())
    print(f"{what}: change to tree on screen {lat:.0f} ms (worker {grow:.0f} ms: {times})")
busy = [f for f in frames if f["busy"]]
print(f"frames: {len(frames)}, {len(busy)} while regenerating; longest frame code while regenerating: "
      f"{max((f['took_ms'] for f in busy), default=0):.1f} ms; longest gap between frames while regenerating: "
      f"{max((f['gap_ms'] for f in busy), default=0):.1f} ms")
PY
