# Sourced by the timed benchmark scripts (scripts/bench_*.sh).

# The 1-minute load average.
load() { cut -d' ' -f1 /proc/loadavg; }

# Timings mean little while other jobs run: waits (at most 20 min) for a
# quiet machine, then says how loaded it was.
wait_for_quiet_machine() {
  for ((i = 0; i < 40; i++)); do
    awk -v l="$(load)" 'BEGIN { exit !(l < 1.0) }' && break
    sleep 30
  done
  echo "load average (1 min) before the timed runs: $(load)"
}

# The benchmark's working folder in `work`: LOOKBOTH_BENCH_DIR (kept, with
# what it renders, for the next run), else a temporary one removed at exit.
bench_work_dir() {
  if [[ -n ${LOOKBOTH_BENCH_DIR:-} ]]; then
    work=$LOOKBOTH_BENCH_DIR
    mkdir -p "$work"
  else
    work="$(mktemp -d)"
    trap 'rm -rf "$work"' EXIT
  fi
}

# timed_run NAME CMD...: runs CMD (its output in $work/out_NAME.txt) and
# appends its wall time in ms to $work/t_NAME; stops the script when it fails.
timed_run() {
  local name=$1; shift
  local t0 t1
  t0=$(date +%s%N)
  "$@" >"$work/out_$name.txt" 2>"$work/stderr.txt" || { cat "$work/stderr.txt" >&2; exit 1; }
  t1=$(date +%s%N)
  echo $(( (t1 - t0) / 1000000 )) >>"$work/t_$name"
}
