#!/usr/bin/env bash
# `pvcap dataset` on a small simulated dataset: N participants (default 3), each one session of a
# short protocol (a press at three force levels and a palm press at two, with each hand: 10 takes)
# on the full-size simulated rig (four 1920x1080 cameras, the Sensel), their pads calibrated with
# the simulator's lenses. Prints the catalogue's first scan and rescan per session, and a release's
# time per session locally and through a one-node Slurm cluster started here (munged, slurmctld,
# slurmd in a network namespace of the bench's, stopped by their pids at the end). Removes all it
# made. Needs root, and slurm-wlm and munge (scripts/deps.sh --tests).
#
#   bash bench/dataset_bench.sh [participants]
#   bash bench/dataset_bench.sh --short   (the suite's short form: records nothing; the dataset is a
#                                          copy of the export tests' session, PVCAP_EXPORT_FIXTURE;
#                                          every step and line, figures not to quote)
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
pvcap=$here/build/app/pvcap
short=0
if [ "${1:-}" = "--short" ]; then short=1; shift; fi
n=${1:-3}
work=$(mktemp -d /tmp/pvcap-dataset-bench-XXXXXX)
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  sleep 1
  for p in "${pids[@]}"; do kill -9 "$p" 2>/dev/null || true; done
  rm -rf "$work"
}
trap cleanup EXIT
now() { date +%s.%N; }
per() { /usr/bin/python3 -c "import sys; a, b, n = map(float, sys.argv[1:]); print(f'{b - a:.2f} s, {(b - a) / n:.2f} s per session')" "$@"; }

mkdir -p "$work/pictograms"
cp "$here/rig-configs/protocols/pictograms/press_index_finger.svg" "$here/rig-configs/protocols/pictograms/press_palm.svg" \
  "$work/pictograms/"
cat > "$work/protocol.yaml" <<'YAML'
name: bench
fast_timings: {prompt_s: 0.4, countdown_s: 0.3, record_s: 2.0, rest_s: 0.3}
actions:
  - {name: press_index_finger, text: Press with your index finger, pictogram: pictograms/press_index_finger.svg,
     forces: [low, high, no_contact], repetitions: 2}
  - {name: press_palm, text: Press with your palm, pictogram: pictograms/press_palm.svg, forces: [low, high],
     repetitions: 2}
YAML
if ((short)); then
  fixture=${PVCAP_EXPORT_FIXTURE:?--short reads the export tests\' session (ctest sets PVCAP_EXPORT_FIXTURE)}
  n=0
  mkdir -p "$work/sessions"
  cp -a "$fixture/sessions/." "$work/sessions/"
  cp -a "$fixture/protocol.yaml" "$work/protocol.yaml"
  cp -a "$fixture/pictograms/." "$work/pictograms/"
  echo "the export tests' session, copied into $work"
else
  echo "recording $n participants into $work"
fi
for i in $(seq 1 "$n"); do
  code=$(printf 'B%02d' "$i")
  "$pvcap" session --rig "$here/rig-configs/sim.yaml" --root "$work/sessions" --protocol "$work/protocol.yaml" --auto \
    --fast --no-web --participant "$code" --skin-tone light --lighting LCR > "$work/$code.log" 2>&1 \
    || { echo "the session of $code failed: $work/$code.log" >&2; exit 1; }
done
for s in "$work"/sessions/*/; do bash "$here/bench/calibrate_sim_pad.sh" "${s%/}"; done
sessions=$(ls -d "$work"/sessions/*/ | wc -l)
"$pvcap" --log-level warn dataset init "$work/dataset" --protocol "$work/protocol.yaml" --sessions "$work/sessions" \
  --license https://creativecommons.org/licenses/by-nc/4.0/ --url https://example.org/bench --creator Bench > /dev/null

t0=$(now); "$pvcap" --log-level warn dataset status "$work/dataset" > /dev/null; t1=$(now)
"$pvcap" --log-level warn dataset status "$work/dataset" > /dev/null; t2=$(now)
echo "dataset scan, first: $sessions sessions in $(per "$t0" "$t1" "$sessions") (verify, report figures and self-check of each)"
echo "dataset scan, again with nothing changed: $(per "$t1" "$t2" "$sessions")"
test_share=1; ((short)) && test_share=0  # one participant: all for training
"$pvcap" --log-level warn dataset split "$work/dataset" --test "$test_share" --val 0 --seed 1 > /dev/null

t0=$(now); "$pvcap" --log-level warn dataset release "$work/dataset" --out "$work/local" > "$work/local.log"; t1=$(now)
echo "dataset release, local (--jobs 2): $(per "$t0" "$t1" "$sessions"); $(tail -1 "$work/local.log" | cut -d';' -f1-2)"

# A one-node Slurm cluster in a network namespace of its own (as tests/integration/slurm_cluster.cpp).
c=$work/cluster
mkdir -p "$c/state" "$c/spool" "$c/munge"
chmod 700 "$c/munge"
head -c 128 /dev/urandom > "$c/munge/munge.key"
chmod 400 "$c/munge/munge.key"
cat > "$c/slurm.conf" <<CONF
ClusterName=pvcapbench
SlurmctldHost=localhost(127.0.0.1)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$c/munge/munge.socket
StateSaveLocation=$c/state
SlurmdSpoolDir=$c/spool
SlurmctldPidFile=$c/slurmctld.pid
SlurmdPidFile=$c/slurmd.pid
SlurmctldLogFile=$c/slurmctld.log
SlurmdLogFile=$c/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SchedulerType=sched/builtin
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
JobCompType=jobcomp/none
AccountingStorageType=accounting_storage/none
MpiDefault=none
NodeName=localhost NodeAddr=127.0.0.1 CPUs=2 State=UNKNOWN
PartitionName=debug Nodes=localhost Default=YES MaxTime=INFINITE State=UP
CONF
unshare -n sh -c "ip link set lo up && ip addr add 10.254.0.1/32 dev lo &&
  munged --force --socket=$c/munge/munge.socket --key-file=$c/munge/munge.key --pid-file=$c/munge/munged.pid \
    --log-file=$c/munge/munged.log --seed-file=$c/munge/seed &&
  slurmctld -f $c/slurm.conf && slurmd -f $c/slurm.conf -N localhost"
sleep 1
for f in "$c/slurmctld.pid" "$c/slurmd.pid" "$c/munge/munged.pid"; do pids+=("$(cat "$f")"); done
in_cluster="nsenter --net=/proc/${pids[0]}/ns/net env SLURM_CONF=$c/slurm.conf"
for _ in $(seq 1 150); do $in_cluster sinfo -h -o %t 2>/dev/null | grep -q idle && break; sleep 0.2; done
t0=$(now)
$in_cluster "$pvcap" --log-level warn dataset release "$work/dataset" --out "$work/slurm" --scheduler slurm --wait \
  > "$work/slurm.log"
t1=$(now)
echo "dataset release, Slurm (one node, 2 CPUs, a task per session): $(per "$t0" "$t1" "$sessions")"
logs=$(echo "$work"/dataset/releases/*slurm-*/slurm-logs)
echo "  its tasks took: $(cat "$logs"/*_*.log | sed -n 's/.* exported in \(.*\) s$/\1 s/p' | tr '\n' ' '); the final job: $(sed -n 's/.*finished in \(.*\) s;.*/\1 s/p' "$logs"/finish-*.log)"
# When the controller started and ended each job, from its log (seconds after the submission).
/usr/bin/python3 - "$c/slurmctld.log" "$t0" <<'PY'
import re, sys, datetime
t0 = float(sys.argv[2])
for line in open(sys.argv[1]):
    m = re.match(r"\[(\S+)\] (.*)", line)
    if not m or not re.search(r"sched: Allocate|_job_complete: JobId=\S+ done", m.group(2)):
        continue
    t = datetime.datetime.fromisoformat(m.group(1)).timestamp()
    print(f"  controller at +{t - t0:6.1f} s: {m.group(2)[:90]}")
PY
if diff -r "$work/local" "$work/slurm" > /dev/null; then echo "the Slurm release equals the local one file for file"
else echo "the Slurm release differs from the local one"; exit 1; fi
