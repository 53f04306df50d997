# Sourced by the bench scripts. `bench_work_dir NAME` makes /tmp/pvcap-NAME-XXXXXX, names it in
# $work, and removes it when the script ends: a recorded 4-camera session is ~1 GB per 15 s, and a
# full disk stops sessions. PVCAP_BENCH_KEEP=1 keeps it, and so does a failed run (for its logs);
# the script then says where it is.
bench_work_dir() {
  work=$(mktemp -d "/tmp/pvcap-$1-XXXXXX")
  trap bench_work_cleanup EXIT
}
bench_work_cleanup() {
  local rc=$?
  if [ "${PVCAP_BENCH_KEEP:-0}" = 1 ] || [ "$rc" -ne 0 ]; then
    echo "(left for a look, remove it when done: $work)" >&2
  else
    rm -rf "$work"
  fi
}
