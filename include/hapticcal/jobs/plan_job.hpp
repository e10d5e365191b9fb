// `hapticcal plan` as a typed request (the command line's and the Python
// module's options): checked and resolved into a PlanProblem's
// inputs, and the plan's files (plan.csv, plan.json, the report) written.
#pragma once

#include <Eigen/Core>
#include <array>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "hapticcal/core/output_set.hpp"
#include "hapticcal/design/plan.hpp"
#include "hapticcal/jobs/command_options.hpp"
#include "hapticcal/jobs/iso_plan_job.hpp"
#include "hapticcal/model/model.hpp"

namespace hapticcal {

struct PlanRequest {
  std::string model, measurement, candidates, criterion = "i";
  std::vector<std::string> columns;  // the candidates log's, if it has no header line
  std::string tip, root;
  std::vector<std::string> fix, free;  // as calibrate's
  // Random candidates only where the tool point is [MIN, MAX] m from the origin
  // of the measurement frame, and inside the box [x0, x1, y0, y1, z0, z1] m.
  std::optional<std::array<double, 2>> distance_range;
  std::optional<std::array<double, 6>> box;
  std::optional<int> poses;  // required (check_plan_command)
  std::optional<int> pool;   // none: PlanOptions' default
  unsigned long long seed = 1;
  // None: the defaults (the kind's among kPaperSigmaMPaper and kPlanSigmaPosition;
  // kPaperSigmaE).
  std::optional<double> sigma, sigma_e;
  std::optional<int> refine_passes;  // none: PlanOptions' default
};

// A request resolved: what PlanProblem and plan_poses take.
struct PlanSetup {
  DeviceModel model;
  MeasurementType type = MeasurementType::kDistance;
  PlanOptions options;
  double sigma = 0, sigma_e = 0;
  Eigen::MatrixXd analysis;  // the readings the identifiability is tested on
  std::vector<std::string> fix, free;
  bool user_candidates = false;  // options.candidates from the request's log
};

// Every problem of the request (a name, a number, a file, a log) is an
// InputError with the command line's option name in its message.
PlanSetup prepare_plan(const PlanRequest& request);

// plan.json's text (format hapticcal-plan/1).
std::string plan_json(const PlanRequest& request, const PlanSetup& setup,
                      const PlanProblem& problem, const Plan& plan);

// The whole command as one job (issue 24): the request resolved, the problem,
// the plan and its files in `out` (an OutputSet, committed).
struct PlanJob {
  PlanSetup setup;
  std::unique_ptr<PlanProblem> problem;
  Plan plan;
  std::string json;                // plan.json's text
  std::unique_ptr<OutputSet> out;  // committed
  int figures = 0;                 // drawn into its report
  std::string report_note;         // write_report's note, or empty
};
// `started` is called once the problem is set up, before the search;
// `progress` gets the search's progress lines. Throws InputError for bad input
// (poses outside 1..100000 among it).
PlanJob run_plan_job(const PlanRequest& request, const std::string& out,
                     const std::function<void(const PlanSetup&, const PlanProblem&)>& started = {},
                     const std::function<void(const std::string&)>& progress = {});

// `plan` as both front ends give it: an experiment design, or with iso9283 the
// ISO 9283 test cube instead (jobs/iso_plan_job.hpp); the model, tip and root
// go to both requests.
struct PlanCommandRequest {
  PlanRequest plan;
  bool iso9283 = false;
  IsoPlanRequest iso;
  std::string out = "hapticcal-out/plan";
};

// plan's options, bound by the command line and the Python module alike.
const CommandOptions<PlanCommandRequest>& plan_options();

// The options that belong to the other kind of plan, or a design without its
// measurement and poses: an InputError naming them.
void check_plan_command(const PlanCommandRequest& request);

// Writes plan.csv, plan.json (its text `json`, plan_json's) and report.html
// with its figures into `dir`; returns the number of figures drawn and sets
// `note` as write_report does.
int write_plan_files(const std::string& dir, const std::string& json, const PlanProblem& problem,
                     const Plan& plan, std::string& note);

}  // namespace hapticcal
