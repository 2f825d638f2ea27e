#!/usr/bin/env bash
# Table 4 of the paper, here: the shipped training config at an equal, smaller budget, with one
# part removed per row; each model evaluated on the held-out shapes (metrics of the network's
# own output, no simulation). Usage: benches/ablations.sh [STEPS] [OUT_DIR]
set -euo pipefail
steps=${1:-1500}
out=${2:-target/ablations}
bin=${PHYSSKIN:-target/release/physskin}
mkdir -p "$out"
python3 - "$steps" > "$out/config.json" <<'PY'
import json, sys
c = json.load(open("config/training.json"))
c["steps"] = int(sys.argv[1])
c["checkpoint_every"] = 500
print(json.dumps(c, indent=2))
PY
for variant in full no-normalization no-oni no-config no-orth no-smooth; do
  flag=""
  [ "$variant" != full ] && flag="--$variant"
  if [ ! -f "$out/$variant/model.safetensors" ]; then
    "$bin" train --config "$out/config.json" --out "$out/$variant" $flag 2> "$out/$variant.train.log" > /dev/null
  fi
  "$bin" eval --model "$out/$variant/model.safetensors" --no-sim --held-out 12 --json > "$out/$variant.eval.json" 2> /dev/null
done
python3 - "$out" <<'PY'
import json, sys
out = sys.argv[1]
print(f"{'variant':<18} {'omega_x100':>11} {'kappa_log':>10} {'h_spec':>9} {'white_omega_x100':>17}")
for v in ["full", "no-normalization", "no-oni", "no-config", "no-orth", "no-smooth"]:
    m = json.load(open(f"{out}/{v}.eval.json"))["mean"]
    print(f"{v:<18} {m['omega_orth']*100:>11.5f} {m['kappa_log']:>10.4f} {m['h_spec']:>9.5f} {m['whitened_omega_orth']*100:>17.5f}")
PY
