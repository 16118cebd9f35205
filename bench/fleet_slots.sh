#!/usr/bin/env bash
# The engine's overhead per task from a fleet run's own status records, independent of a direct
# run's timing (on a shared machine whose load changes between runs, the difference of two wall
# times is mostly the load): with JOBS slots busy from the first task's start to the last one's
# end, what the slots spent outside the tasks' own [started, ended] is the engine's (its
# scheduling latency, the task's process start before `started`, the status write after `ended`).
#   bash bench/fleet_slots.sh RESULTS_DIR JOBS
#   per task: idle = (JOBS * (last ended - first started) - sum of task durations) / rows
# The start of the first tasks and the end of the last ones are left out (submission, --wait's
# polling): they are paid once per run, not per task. A run whose rows end unevenly (few rows)
# counts the slots left idle at the end as overhead: an upper bound.
set -euo pipefail
results=$1
jobs=${2:-2}
python3 - "$results" "$jobs" <<'PY'
import datetime, glob, json, sys
results, jobs = sys.argv[1], int(sys.argv[2])
def t(s): return datetime.datetime.strptime(s, "%Y-%m-%dT%H:%M:%S.%fZ").timestamp()
spans = []
for f in glob.glob(results + "/*/*.status.json"):
    s = json.load(open(f))
    spans.append((t(s["started"]), t(s["ended"])))
if not spans: sys.exit("no status records under " + results)
n = len(spans)
work = sum(e - b for b, e in spans)
makespan = max(e for _, e in spans) - min(b for b, _ in spans)
idle = (jobs * makespan - work) / n
print(f"{results}: {n} rows, {jobs} slots, makespan {makespan:.1f} s, task time {work / n:.2f} s per row "
      f"(started..ended), slot idle {idle:.3f} s per row = {100 * idle / (work / n):.1f}% of a row's task time")
PY
