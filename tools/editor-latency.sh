#!/usr/bin/env bash
# The editor's latency figures (docs/editor.md, BENCHMARKS.md "Editor latency"): opens
# `sylva edit` on a preset in a real window under Xvfb (Mesa's lavapipe draws), applies
# a leaf, a wind and a generator change one at a time once each tree is shown, closes,
# and summarises the editor's own frame log. Extra arguments go to `sylva edit`.
#   tools/editor-latency.sh [PRESET]     (needs: cargo build --release -p sylva-cli; xvfb-run)
set -euo pipefail
cd "$(dirname "$0")/.."
preset="${1:-wp-quaking-aspen}"
shift || true
log="$(mktemp -d)/frames.jsonl"
xvfb-run -a -s "-screen 0 1280x800x24" target/release/sylva edit "$preset" \
  --frame-log "$log" --close-after-tree 5 \
  --script-set leaves.alpha_cutoff=0.6 \
  --script-set wind.preset=breeze \
  --script-set seed=7 "$@"
python3 - "$log" <<'PY'
import json, sys
rows = [json.loads(l) for l in open(sys.argv[1])]
edits, shown, frames = [], [], []
last_edit = "launch"
for r in rows:
    if "event" in r and r["event"] == "edit":
        last_edit = r["about"]
    elif "tree_shown" in r:
        shown.append([last_edit, r["tree_shown"], r["latency_ms"], r["grow_ms"], r.get("stages_ms", {}), None])
    elif "tree_presented" in r and shown:
        shown[-1][5] = r["latency_ms"]
    elif "frame" in r:
        frames.append(r)
# "shown": the code of the frame that draws the tree ended; "presented": that frame was
# painted and presented (the next frame began), what the user sees.
first = shown[0]
print(f"launch to first tree: shown {first[1]:.0f} ms, presented {first[1] - first[2] + (first[5] or first[2]):.0f} ms (grow {first[3]:.0f} ms)")
for what, at, lat, grow, stages, presented in shown[1:]:
    times = ", ".join(f"{k} {v:.0f}" for k, v in stages.items())
    pres = f"{presented:.0f} ms" if presented is not None else "not logged"
    print(f"{what}: change to tree shown {lat:.0f} ms, presented {pres} (worker {grow:.0f} ms: {times})")
busy = [f for f in frames if f["busy"]]
# A frame's whole CPU cost (app code, egui layout and tessellation, the paint's
# submission) is eframe's figure, logged with the frame after it.
cpu = [f["previous_cpu_ms"] for f in frames if f.get("previous_cpu_ms") is not None]
busy_cpu = [frames[i]["previous_cpu_ms"] for i in range(1, len(frames))
            if frames[i - 1]["busy"] and frames[i].get("previous_cpu_ms") is not None]
print(f"frames: {len(frames)}, {len(busy)} while regenerating (no repaint loop: frames come from input and results)")
print(f"  longest frame code while regenerating: {max((f['took_ms'] for f in busy), default=0):.1f} ms")
print(f"  longest eframe CPU time of a frame while regenerating: {max(busy_cpu, default=0):.1f} ms; "
      f"median of all frames: {sorted(cpu)[len(cpu) // 2] if cpu else 0:.1f} ms")
PY
