#include "fleet/fleet_summary.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cmath>

#include "core/geometry.hpp"

namespace insalign::fleet {
namespace {

using Dofs = std::array<double, 7>;

Iso3 to_transform(const std::array<double, 16>& m) {
  Iso3 T = Iso3::Identity();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) T.matrix()(r, c) = m[static_cast<std::size_t>(4 * r + c)];
  return T;
}

// The change from `ref` to `e` per DOF: translation m, rotation deg (ZYX of R * R_ref^T), time s.
Dofs change(const ExtrinsicRecord& e, const ExtrinsicRecord& ref) {
  const Iso3 T = to_transform(e.T_ins_lidar), T_ref = to_transform(ref.T_ins_lidar);
  const Vec3 dt = T.translation() - T_ref.translation();
  const Vec3 drpy = rpy_from_rotation(T.linear() * T_ref.linear().transpose()) * kDegPerRad;
  return {dt.x(), dt.y(), dt.z(), drpy.x(), drpy.y(), drpy.z(), e.time_offset_s.value_or(0.0) - ref.time_offset_s.value_or(0.0)};
}

double tolerance(const SummaryConfig& c, std::size_t dof) { return dof < 3 ? c.tolerance_m : dof < 6 ? c.tolerance_deg : c.tolerance_time_s; }
const char* unit(std::size_t dof) { return dof < 3 ? "m" : dof < 6 ? "deg" : "s"; }

// Between consecutive calibrations: the determined DOFs that moved beyond tolerance and noise.
std::string calibration_jump(const ExtrinsicRecord& e, const ExtrinsicRecord& prev, const SummaryConfig& c) {
  const Dofs d = change(e, prev);
  std::string what;
  for (std::size_t i = 0; i < 7; ++i) {
    if (!e.determined[i].value_or(i == 6) || !prev.determined[i].value_or(i == 6)) continue;
    const double s = std::hypot(e.stddev[i].value_or(0.0), prev.stddev[i].value_or(0.0));
    if (std::abs(d[i]) > tolerance(c, i) && std::abs(d[i]) > c.knock_sigma * s)
      what += fmt::format("{}{} {:+.3f} {}", what.empty() ? "" : ", ", kFleetDofs[i], d[i], unit(i));
  }
  return what;
}

std::string drifted_dofs(const ExtrinsicRecord& e) {
  std::string what;
  for (std::size_t i = 0; i < 7; ++i)
    if (e.dof_verdict[i] == "drifted")
      what += fmt::format("{}{} {:+.3f} {}", what.empty() ? "" : ", ", kFleetDofs[i], e.correction[i].value_or(0.0), unit(i));
  return what;
}

struct CarRuns {
  std::vector<const RunRecord*> runs;  // by date
  std::map<std::string, std::vector<const ExtrinsicRecord*>> by_run;
};

void add_series(CarSummary& car, const CarRuns& cr, const SummaryConfig& c) {
  std::map<std::string, const ExtrinsicRecord*> first_calibration, last_calibration;
  std::map<std::string, std::string> last_calibration_date;
  std::string last_check_verdict, last_check_date;
  for (const RunRecord* r : cr.runs) {
    const auto it = cr.by_run.find(r->id);
    if (it == cr.by_run.end()) continue;
    std::string check_knock;
    for (const ExtrinsicRecord* e : it->second) {
      auto& series = car.series[e->lidar];
      if (r->kind == "check") {
        for (std::size_t i = 0; i < 7; ++i)
          if (e->correction[i]) series[i].push_back({r->date, r->id, r->kind, *e->correction[i], e->stddev[i], e->dof_verdict[i]});
        if (r->verdict == "recalibrate") check_knock += (check_knock.empty() ? "" : "; ") + drifted_dofs(*e);
        continue;
      }
      if (!first_calibration.count(e->lidar)) first_calibration[e->lidar] = e;
      const Dofs d = change(*e, *first_calibration[e->lidar]);
      for (std::size_t i = 0; i < 7; ++i) series[i].push_back({r->date, r->id, r->kind, d[i], e->stddev[i], ""});
      if (last_calibration.count(e->lidar)) {
        const std::string what = calibration_jump(*e, *last_calibration[e->lidar], c);
        if (!what.empty())
          car.knocks.push_back({r->date, last_calibration_date[e->lidar], r->id,
                                (e->lidar == "lidar" ? "" : e->lidar + ": ") + what + " (between calibrations)"});
      }
      last_calibration[e->lidar] = e;
      last_calibration_date[e->lidar] = r->date;
    }
    if (r->kind == "check") {
      if (r->verdict == "recalibrate" && last_check_verdict != "recalibrate")
        car.knocks.push_back({r->date, last_check_date, r->id, (check_knock.empty() ? "recalibrate" : check_knock) + " (check)"});
      last_check_verdict = r->verdict;
      last_check_date = r->date;
    }
  }
}

// The car's state from its latest runs: a check's verdict stands until a later run; a knock seen
// between calibrations asks for the new extrinsic to be installed unless a later check says ok.
void decide_state(CarSummary& car, const CarRuns& cr) {
  const RunRecord* latest = nullptr;
  const RunRecord* latest_check = nullptr;
  for (const RunRecord* r : cr.runs) {
    if (r->verdict == "failed") continue;
    latest = r;
    if (r->kind == "check") latest_check = r;
  }
  if (latest == nullptr) {
    car.state = "failed";
    car.why = "no row reached a verdict";
    if (!cr.runs.empty()) car.latest_date = cr.runs.back()->date, car.latest_run = cr.runs.back()->id, car.latest_verdict = "failed";
    return;
  }
  car.latest_date = latest->date;
  car.latest_run = latest->id;
  car.latest_verdict = latest->verdict;
  car.latest_report = latest->report;
  car.state = latest->verdict;
  const Knock* calibration_knock = nullptr;
  for (const Knock& k : car.knocks)
    if (k.what.find("(between calibrations)") != std::string::npos) calibration_knock = &k;
  if (latest_check != nullptr && latest_check->verdict == "recalibrate") {
    car.state = "recalibrate";
    car.needs_recalibration = true;
    car.why = "the check of " + latest_check->date + " found the installed extrinsic off";
  } else if (calibration_knock != nullptr && (latest_check == nullptr || latest_check->date < calibration_knock->date)) {
    car.state = "changed";
    car.needs_recalibration = true;
    car.why = "the calibration of " + calibration_knock->date + " differs from the one of " + calibration_knock->after + ": " +
              calibration_knock->what + "; install the new extrinsic";
  }
}

}  // namespace

FleetSummary summarize_fleet(const std::vector<RunRecord>& runs, const std::vector<ExtrinsicRecord>& extrinsics,
                             const SummaryConfig& config) {
  FleetSummary out;
  out.runs = runs;
  std::sort(out.runs.begin(), out.runs.end(),
            [](const RunRecord& a, const RunRecord& b) { return std::tie(a.car, a.date, a.id) < std::tie(b.car, b.date, b.id); });
  std::map<std::string, CarRuns> cars;
  for (const RunRecord& r : out.runs) {
    cars[r.car].runs.push_back(&r);
    if (r.verdict == "failed") out.failed.push_back(r);
  }
  std::map<std::string, std::string> car_of_run;
  for (const RunRecord& r : out.runs) car_of_run[r.id] = r.car;
  for (const ExtrinsicRecord& e : extrinsics)
    if (car_of_run.count(e.run_id)) cars[car_of_run[e.run_id]].by_run[e.run_id].push_back(&e);
  for (const auto& [name, cr] : cars) {
    CarSummary car;
    car.car = name;
    car.runs = static_cast<int>(cr.runs.size());
    for (const RunRecord* r : cr.runs) car.failed += r->verdict == "failed";
    add_series(car, cr, config);
    decide_state(car, cr);
    out.cars.push_back(std::move(car));
  }
  std::stable_sort(out.cars.begin(), out.cars.end(), [](const CarSummary& a, const CarSummary& b) {
    return a.needs_recalibration > b.needs_recalibration;
  });
  return out;
}

}  // namespace insalign::fleet
