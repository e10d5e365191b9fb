// `evaluate` as one job (jobs/evaluate_job.hpp).
#include "hapticcal/jobs/evaluate_job.hpp"

#include <fmt/format.h>

#include "hapticcal/core/error.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/data_io/fixture.hpp"
#include "hapticcal/data_io/log.hpp"
#include "hapticcal/identification/markers.hpp"
#include "hapticcal/model_io/model_source.hpp"
#include "hapticcal/report/report.hpp"
#include "hapticcal/report/results_json.hpp"

namespace hapticcal {
namespace {

// A model file: a URDF with the request's chain, a device file as it is.
DeviceModel load_evaluated_model(const EvaluateRequest& request, const std::string& path) {
  return is_urdf_path(path) ? load_model(path, request.tip, request.root) : load_model(path);
}

// --tip and --root apply to URDF models: given without one, a usage error.
void check_chain_used(const EvaluateRequest& request) {
  if (request.tip.empty() && request.root.empty()) return;
  for (const std::string& path : {request.model, request.reference}) {
    if (!path.empty() && is_urdf_path(path)) return;
  }
  if (request.given || request.given_reference) return;  // models loaded by the caller
  throw InputError(fmt::format("{}: applies to URDF models (.urdf); none is given",
                               request.tip.empty() ? "--root" : "--tip"));
}

}  // namespace

EvaluateJob run_evaluate_job(const EvaluateRequest& request) {
  check_chain_used(request);
  EvaluateJob job;
  job.model = request.given ? *request.given : load_evaluated_model(request, request.model);
  Log log = read_log(request.log, request.columns);
  if (log.marker_count > 0) log = markers_to_poses(log, request.marker_body).poses;
  job.rows = log.rows;
  const Fixture known = fixture_facts(request.fixture, request.point_distances);
  const bool referenced = request.given_reference || !request.reference.empty();
  if (referenced) {
    const DeviceModel reference = request.given_reference
                                      ? *request.given_reference
                                      : load_evaluated_model(request, request.reference);
    job.comparison = compare_to_reference(job.model, reference, log, known.distances, known.points,
                                          request.registration);
    job.evaluation = job.comparison->model;
  } else if (request.registration) {
    job.evaluation =
        evaluate_registered(job.model, log, *request.registration, known.distances, known.points);
  } else {
    job.evaluation = evaluate(job.model, log, known.distances, known.points);
  }
  const EvaluationComparison* cmp = job.comparison ? &*job.comparison : nullptr;
  job.json = evaluation_json(cmp, job.evaluation);
  job.lines = evaluation_lines(cmp, job.evaluation, request.reference);
  if (!request.out) return job;
  job.out = std::make_unique<OutputSet>(*request.out, "evaluate");
  write_file_atomically(job.out->dir() + "/results.json", job.json + "\n");
  job.figures =
      write_report(evaluation_report(job.model, request.model, log, job.evaluation,
                                     cmp ? &cmp->reference : nullptr, request.reference, job.lines),
                   job.out->dir(), job.report_note);
  job.out->commit();
  return job;
}

}  // namespace hapticcal
