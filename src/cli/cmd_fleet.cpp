// insalign fleet run|task|ingest|report: a fleet of drives on the batch engine a site has
// (CONVENTIONS.md "Fleets"). The work is in src/fleet; this file only reads options.
#include <fmt/core.h>

#include <memory>

#include "cli/commands.hpp"
#include "core/errors.hpp"
#include "fleet/dashboard.hpp"
#include "fleet/engine_kubernetes.hpp"
#include "fleet/engine_local.hpp"
#include "fleet/engine_slurm.hpp"
#include "fleet/ingest.hpp"
#include "fleet/rows.hpp"
#include "fleet/task.hpp"

namespace insalign::cli {
namespace {

namespace fs = std::filesystem;

struct FleetOptions {
  std::string manifest, results, engine = "local", db, out;
  long index = -1;
  bool wait = false, force = false;
  fleet::SlurmConfig slurm;
  fleet::KubernetesConfig kubernetes;
  std::size_t jobs = 2;
};

int finish(const fleet::Manifest& m, const fs::path& results, const std::map<std::size_t, std::string>& engine_states = {}) {
  const std::vector<fleet::RowReport> reports = fleet::row_reports(m, results, engine_states);
  fmt::print("{}", fleet::summarize(reports));
  return fleet::all_done(reports) ? kExitOk : kExitOther;
}

int run_fleet(FleetOptions& o) {
  const fleet::Manifest m = fleet::read_manifest(o.manifest);  // a bad manifest stops here, before anything runs
  const fs::path results = fs::absolute(o.results);
  if (o.engine == "local") {
    fleet::run_local(m, results, {o.jobs, o.force, {}});
    return finish(m, results);
  }
  if (o.engine == "slurm") {
    o.slurm.jobs = o.jobs;
    o.slurm.force = o.force;
    const std::string job = fleet::submit_slurm(m, results, o.slurm);
    if (job.empty()) {
      fmt::print("nothing to run: every row is done (--force reruns them)\n");
      return finish(m, results);
    }
    fmt::print("submitted Slurm job {} ({}/slurm/fleet.sbatch)\n", job, results.string());
    if (m.rows.size() > o.jobs)  // only rows that wait for a slot pay slurmctld's latency
      for (const std::string& hint : fleet::slurm_latency_hints()) fmt::print(stderr, "note: {}\n", hint);
    std::fflush(stdout);
    if (!o.wait) return kExitOk;
    return finish(m, results, fleet::wait_slurm(m, job, o.slurm));
  }
  o.kubernetes.jobs = o.jobs;
  o.kubernetes.force = o.force;
  const fs::path job = fleet::write_kubernetes(m, results, o.kubernetes);
  fmt::print("wrote {} and {}\nbuild the image: docker build -f {} -t {} <insalign source folder>\nthen: kubectl apply -f {}\n",
             job.string(), (job.parent_path() / "Dockerfile").string(), (job.parent_path() / "Dockerfile").string(),
             o.kubernetes.image, job.string());
  return kExitOk;
}

int run_task(const FleetOptions& o) {
  const fleet::Manifest m = fleet::read_manifest(o.manifest);
  const long index = o.index >= 0 ? o.index : fleet::index_from_environment();
  if (index < 0) throw InputError(o.manifest, "", "no --index and neither SLURM_ARRAY_TASK_ID nor JOB_COMPLETION_INDEX is set");
  if (static_cast<std::size_t>(index) >= m.rows.size())
    throw InputError(o.manifest, "", fmt::format("index {} is beyond the manifest's {} rows", index, m.rows.size()));
  const fleet::TaskOutcome out = fleet::run_task(m, static_cast<std::size_t>(index), fs::absolute(o.results), {o.force, {}});
  const std::string id = m.rows[static_cast<std::size_t>(index)].id();
  if (out.skipped) {
    fmt::print("{}: skipped, {}\n", id, out.skip_reason);
    return kExitOk;
  }
  const fleet::TaskStatus& s = out.status;
  fmt::print("{}: exit {} after attempt {}{}\n", id, s.exit_code, s.attempts, s.error.empty() ? "" : ": " + s.error);
  // The row's own failure is in its status; only a task stopped by a signal tells the engine so
  // (Kubernetes then retries the index; Slurm shows the task as failed).
  return s.exit_code > 128 ? s.exit_code : kExitOk;
}

void ingest_into(const fs::path& results, fleet::SqlConnection& db) {
  const fleet::IngestSummary s = fleet::ingest_results(results, db);
  fmt::print("ingested {}: {} new, {} replaced, {} unchanged\n", results.string(), s.inserted, s.replaced, s.unchanged);
  for (const std::string& why : s.unreadable) fmt::print(stderr, "warning: skipped {}\n", why);
}

int run_ingest(const FleetOptions& o) {
  const fs::path results = fs::absolute(o.results);
  std::unique_ptr<fleet::SqlConnection> db = fleet::open_database(o.db, results);
  ingest_into(results, *db);
  return kExitOk;
}

int run_report(const FleetOptions& o) {
  const fs::path out = fs::absolute(o.out);
  // The default history lives in the results folder: a report of a results folder loads its rows
  // first (ingest is idempotent), so that manifest, run and report are a whole fleet.
  if (o.db.empty() && !fleet::find_status_files(out).empty()) {
    std::unique_ptr<fleet::SqlConnection> db = fleet::open_database(o.db, out);
    ingest_into(out, *db);
  }
  if (o.db.empty() && !fs::exists(out / "fleet.sqlite"))  // not created empty by asking
    throw InputError((out / "fleet.sqlite").string(), "", "no fleet history (run fleet ingest --results " + out.string() + " first, or give --db)");
  std::unique_ptr<fleet::SqlConnection> db = fleet::open_database(o.db, out);
  if (fleet::schema_version(*db) == 0) throw InputError(o.db.empty() ? (out / "fleet.sqlite").string() : o.db, "", "no fleet history (run fleet ingest first)");
  fleet::migrate(*db);
  const fleet::FleetSummary s = fleet::summarize_fleet(fleet::load_runs(*db), fleet::load_extrinsics(*db));
  fleet::write_dashboard(s, out);
  int needing = 0;
  for (const auto& c : s.cars) needing += c.needs_recalibration;
  fmt::print("{} cars, {} need recalibration, {} failed rows: {}\n", s.cars.size(), needing, s.failed.size(), (out / "fleet.html").string());
  return kExitOk;
}

void add_run(CLI::App& fleet_app, const std::shared_ptr<FleetOptions>& o, std::shared_ptr<int>& which) {
  CLI::App* run = fleet_app.add_subcommand("run", "run every row of a manifest on an engine");
  run->add_option("MANIFEST", o->manifest, "the manifest CSV (car,date,kind,input,extrinsic,options)")->required();
  run->add_option("--results", o->results, "results folder DIR")->required();
  run->add_option("--engine", o->engine, "local | slurm | kubernetes")->check(CLI::IsMember({"local", "slurm", "kubernetes"}))->capture_default_str();
  run->add_option("--jobs", o->jobs, "tasks at once (local pool size, Slurm array % limit, Kubernetes parallelism)")
      ->check(CLI::Range(1, 100000))->capture_default_str();
  run->add_flag("--wait", o->wait, "slurm: follow the job to its end and report every row's state");
  run->add_flag("--force", o->force, "rerun rows that are done");
  run->add_option("--partition", o->slurm.partition, "slurm: the partition (default: the cluster's)");
  run->add_option("--sbatch-option", o->slurm.sbatch_options, "slurm: one more #SBATCH line, e.g. --sbatch-option=--account=calib");
  run->add_option("--cpus-per-task", o->slurm.cpus_per_task, "slurm: cores per task")->check(CLI::Range(1, 1024))->capture_default_str();
  run->add_option("--poll-s", o->slurm.poll_s, "slurm --wait: seconds between squeue polls")->check(CLI::Range(0.1, 3600.0))->capture_default_str();
  run->add_option("--image", o->kubernetes.image, "kubernetes: the container image")->capture_default_str();
  run->add_option("--volume-claim", o->kubernetes.volume_claim, "kubernetes: PersistentVolumeClaim with the manifest, recordings and results")
      ->capture_default_str();
  run->callback([which] { *which = 1; });
}

void add_task(CLI::App& fleet_app, const std::shared_ptr<FleetOptions>& o, std::shared_ptr<int>& which) {
  CLI::App* task = fleet_app.add_subcommand("task", "run one manifest row (what every engine's task runs)");
  task->add_option("MANIFEST", o->manifest, "the manifest CSV")->required();
  task->add_option("--results", o->results, "results folder DIR")->required();
  task->add_option("--index", o->index, "0-based row (default: SLURM_ARRAY_TASK_ID or JOB_COMPLETION_INDEX)");
  task->add_flag("--force", o->force, "rerun the row even when it is done");
  task->callback([which] { *which = 2; });
}

}  // namespace

Command make_fleet_command() {
  auto o = std::make_shared<FleetOptions>();
  auto which = std::make_shared<int>(0);
  return {[o, which](CLI::App& app) mutable {
            CLI::App* fleet_app = app.add_subcommand("fleet", "run, record and report a fleet of checks and calibrations");
            fleet_app->require_subcommand(1);
            add_run(*fleet_app, o, which);
            add_task(*fleet_app, o, which);
            CLI::App* ingest = fleet_app->add_subcommand("ingest", "load every row's result into the history database");
            ingest->add_option("--results", o->results, "results folder DIR")->required();
            ingest->add_option("--db", o->db, "sqlite:PATH or postgresql://user@host:port/db (default sqlite:DIR/fleet.sqlite)");
            ingest->callback([which] { *which = 3; });
            CLI::App* report = fleet_app->add_subcommand("report", "write the fleet dashboard, fleet.json and fleet.html");
            report->add_option("--db", o->db, "sqlite:PATH or postgresql://... (default sqlite:OUT/fleet.sqlite)");
            report->add_option("--out", o->out, "folder for fleet.json and fleet.html (a results folder: its rows are ingested first, without --db)")
                ->required();
            report->callback([which] { *which = 4; });
            return fleet_app;
          },
          [o, which] {
            switch (*which) {
              case 1: return run_fleet(*o);
              case 2: return run_task(*o);
              case 3: return run_ingest(*o);
              case 4: return run_report(*o);
            }
            return kExitUsage;
          }};
}

}  // namespace insalign::cli
