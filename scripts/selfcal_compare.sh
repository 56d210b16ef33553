#!/usr/bin/env bash
# Ours (`rodlog calib self`) vs the OpenCV peer (opencv_peer_selfcal.py) on calib-18
# recordings: default (perturbed arm, encoder noise) and clean, RGB-D and mono, N seeds.
# Usage: scripts/selfcal_compare.sh OUTDIR [SEEDS...]   (default seeds 1 2 3 4 5)
# Env: RODLOG (binary, default target/release/rodlog), PY (default .venv-ref/bin/python).
# Writes OUTDIR/results.jsonl (one scored result per line) and prints the median table.
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
out="$1"; shift
seeds=("${@:-1 2 3 4 5}")
[ $# -eq 0 ] && seeds=(1 2 3 4 5)
rodlog="${RODLOG:-$here/target/release/rodlog}"
py="${PY:-$here/.venv-ref/bin/python}"
mkdir -p "$out"
: > "$out/results.jsonl"
for seed in "${seeds[@]}"; do
  for arm in default clean; do
    rec="$out/calib18_${arm}_s${seed}.mcap"
    if [ ! -f "$rec" ]; then
      extra=()
      [ "$arm" = clean ] && extra=(--set robot.perturbation=false --set robot.encoder_noise=false)
      "$rodlog" record --scenario calib-18 --seed "$seed" "${extra[@]}" --out "$rec" > /dev/null
    fi
    for mode in rgbd mono; do
      tag="${arm}_s${seed}_${mode}"
      flag=(); [ "$mode" = mono ] && flag=(--mono)
      "$rodlog" calib self "$rec" --json "${flag[@]}" > "$out/ours_$tag.json" 2> "$out/ours_$tag.err" || true
      "$py" "$here/scripts/opencv_peer_selfcal.py" "$rec" --mode "$mode" > "$out/peer_$tag.json" 2> "$out/peer_$tag.err" || true
      "$py" "$here/scripts/selfcal_truth_errors.py" "$rec" "ours=$out/ours_$tag.json" "peer=$out/peer_$tag.json" \
        | sed "s/^{/{\"arm\": \"$arm\", \"seed\": $seed, \"mode\": \"$mode\", /" >> "$out/results.jsonl"
    done
  done
done
"$py" - "$out/results.jsonl" <<'PYEOF'
import json, sys, statistics as st
rows = [json.loads(l) for l in open(sys.argv[1])]
print("| arm | mode | who | n | e_R median (deg) | e_t median (mm) | e_R max | e_t max |")
print("|---|---|---|---|---|---|---|---|")
for arm in ("default", "clean"):
    for mode in ("rgbd", "mono"):
        for who in ("ours", "peer:best", "peer:tsai", "peer:park", "peer:daniilidis"):
            r = [x for x in rows if x["arm"] == arm and x["mode"] == mode and x["name"] == who and "e_rot_deg" in x]
            if not r:
                continue
            er = [x["e_rot_deg"] for x in r]; et = [x["e_t_mm"] for x in r]
            print(f"| {arm} | {mode} | {who} | {len(r)} | {st.median(er):.4f} | {st.median(et):.3f} | {max(er):.4f} | {max(et):.3f} |")
PYEOF
