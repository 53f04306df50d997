#!/usr/bin/env bash
# Every fuzz target, longer than CI runs them: each for SECONDS or RUNS inputs, whichever comes
# first, one after the other (one core: the machine stays usable). The targets' command lines (seeds,
# dictionaries, options) are read from ctest, so this runs exactly what CI runs, only longer. Each
# target's corpus grows in build/tests/fuzz/corpus_<target> and is kept between runs; findings
# (crash-, leak-, timeout-, oom- inputs) go to build/fuzz-findings/. Prints one line per target:
# inputs run, seconds, inputs/s, coverage (edges, features), corpus size, findings.
#
#   bash bench/fuzz.sh [SECONDS] [RUNS] [TARGET_REGEX]   (default 1200 s, 1000000 inputs, every target)
#
# Both cores: run it twice at once with disjoint TARGET_REGEXes.
#
# A finding: reproduce with `build/tests/fuzz/fuzz_<target> FILE`, fix, and keep FILE among the
# target's seeds in tests/fuzz/seeds_<target>/ (docs/testing.md, Fuzzing).
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
build=$here/build
seconds=${1:-1200}
runs=${2:-1000000}
only=${3:-.}
[ -x "$build/tests/fuzz/fuzz_timeline" ] || { echo "build first: bash scripts/build.sh (needs clang)" >&2; exit 1; }
findings=$build/fuzz-findings
logs=$build/fuzz-logs
mkdir -p "$findings" "$logs"
# The seeds made at test time (from ../shared and a small store written by SessionWriter).
# Two runs of this script at once (targets split over both cores) make them one after the other.
(cd "$build" && flock "$logs/seeds.lock" ctest -R 'fuzz\..*\.seeds$' > "$logs/seeds-$$.log" 2>&1) ||
  { echo "making the seeds failed: $logs/seeds-$$.log" >&2; exit 1; }
rm -f "$logs/seeds-$$.log"

mapfile -t targets < <(cd "$build" && ctest -R '^fuzz\.' --show-only=json-v1 | /usr/bin/python3 -c '
import json, re, sys
only = re.compile(sys.argv[1])
for t in json.load(sys.stdin)["tests"]:
    name = t["name"]
    if name.endswith(".seeds") or not only.search(name): continue
    print(name[len("fuzz."):] + "\t" + "\t".join(t["command"]))' "$only")
[ ${#targets[@]} -gt 0 ] || { echo "no fuzz target matches '$only'" >&2; exit 1; }

printf '%-18s %10s %8s %9s %7s %8s %7s %s\n' target inputs seconds inputs/s edges features corpus findings
for line in "${targets[@]}"; do
  IFS=$'\t' read -r -a parts <<< "$line"
  name=${parts[0]}
  cmd=("${parts[@]:1}")
  args=()
  for a in "${cmd[@]:1}"; do
    case $a in -max_total_time=*|-runs=*) ;; *) args+=("$a") ;; esac
  done
  before=$(ls "$findings" | grep -c "^$name-" || true)
  start=$(date +%s.%N)
  (cd "$build/tests/fuzz" && "${cmd[0]}" "${args[@]}" -max_total_time="$seconds" -runs="$runs" \
     -print_final_stats=1 -artifact_prefix="$findings/$name-") > "$logs/$name.log" 2>&1 || true
  end=$(date +%s.%N)
  after=$(ls "$findings" | grep -c "^$name-" || true)
  /usr/bin/python3 - "$logs/$name.log" "$name" "$start" "$end" "$((after - before))" <<'EOF'
import re, sys
log, name, start, end, found = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4]), int(sys.argv[5])
text = open(log, errors="replace").read()
stats = re.findall(r"^#(\d+)\s+\w+\s+cov: (\d+) ft: (\d+) corp: (\d+)/", text, re.M)
n, cov, ft, corp = stats[-1] if stats else ("0", "?", "?", "?")
m = re.search(r"stat::number_of_executed_units:\s*(\d+)", text)
n = int(m.group(1)) if m else int(n)
secs = end - start
print(f"{name:<18} {n:>10} {secs:>8.0f} {n / max(secs, 1e-9):>9.0f} {cov:>7} {ft:>8} {corp:>7} {found}"
      + ("" if found == 0 else f"  <- see {log}"))
EOF
done
