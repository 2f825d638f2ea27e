#!/usr/bin/env bash
# Runs a bench that prints JSON and keeps what it printed as benches/results/NAME.json, with the
# command, the commit (`-dirty` when the tree had changes outside benches/results and docs/images,
# where benches write their results and plots), the date, the machine
# and the command's wall time, so every
# figure quoted in the README and docs names where it came from.
# Usage: benches/record.sh NAME COMMAND...
set -euo pipefail
name=$1
shift
cd "$(dirname "$0")/.."
out=benches/results/$name.json
printed=$(mktemp)
trap 'rm -f "$printed"' EXIT
started=$(date +%s.%N)
"$@" >"$printed"
finished=$(date +%s.%N)
python3 - "$out" "$printed" "$*" "$started" "$finished" <<'PY'
import json, os, platform, subprocess, sys, datetime
out, printed, command, started, finished = sys.argv[1:6]
commit = subprocess.run(["git", "describe", "--always"], capture_output=True, text=True).stdout.strip()
# Dirty only for changes outside benches/results and docs/images: benches/report.sh records one
# file after another, and some benches draw their plot into docs/images as they run.
changed = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no", "--", ".", ":!benches/results", ":!docs/images"],
                         capture_output=True, text=True).stdout.strip()
if changed:
    commit += "-dirty"
record = {
    "command": command,
    "commit": commit,
    "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
    "machine": f"{platform.machine()}, {os.cpu_count()} cores",
    # The command's wall time, s: what a reader waits for when they run it.
    "wall_s": round(float(finished) - float(started), 1),
    "result": json.load(open(printed)),
}
json.dump(record, open(out, "w"), indent=2)
print(f"wrote {out}")
PY
