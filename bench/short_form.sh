#!/usr/bin/env bash
# A bench's short form in the suite (docs/testing.md, "Benches that cannot rot"): runs COMMAND and
# passes when it exits 0 having printed its figures (a line matching PATTERN), so a change that breaks
# a bench fails CI rather than the next person who measures. It times nothing. With --session, the
# argument SESSION in COMMAND is a copy of the export tests' recorded session (PVCAP_EXPORT_FIXTURE,
# ctest's fixture), made for the run and removed after it: a bench may write into its session.
#   bash bench/short_form.sh PATTERN [--session] -- COMMAND...
set -uo pipefail
pattern=$1
shift
copy=0
if [ "${1:-}" = "--session" ]; then copy=1; shift; fi
[ "${1:-}" = "--" ] || { echo "usage: short_form.sh PATTERN [--session] -- COMMAND..." >&2; exit 2; }
shift
cmd=("$@")
if ((copy)); then
  fixture=${PVCAP_EXPORT_FIXTURE:?the export tests\' session (ctest sets PVCAP_EXPORT_FIXTURE)}
  scratch=$(mktemp -d /tmp/pvcap-bench-short-XXXXXX)
  trap 'rm -rf "$scratch"' EXIT
  cp -a "$fixture/sessions/." "$scratch/" || exit 1
  session=$(ls -d "$scratch"/*/ | head -1)
  for i in "${!cmd[@]}"; do [ "${cmd[$i]}" = SESSION ] && cmd[$i]=${session%/}; done
fi
out=$("${cmd[@]}" 2>&1)
rc=$?
printf '%s\n' "$out"
if [ "$rc" -ne 0 ]; then
  echo "short form: ${cmd[*]} exited $rc" >&2
  exit 1
fi
if ! grep -Eq -- "$pattern" <<< "$out"; then
  echo "short form: ${cmd[*]} ended without its figures (no line matching: $pattern)" >&2
  exit 1
fi
