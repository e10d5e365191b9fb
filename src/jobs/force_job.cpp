// `force` and `convert` as jobs (jobs/force_job.hpp).
#include "hapticcal/jobs/force_job.hpp"

#include <fmt/format.h>

#include <cmath>

#include "hapticcal/core/error.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/model_io/device.hpp"
#include "hapticcal/model_io/model_source.hpp"
#include "hapticcal/model_io/urdf.hpp"
#include "hapticcal/report/report.hpp"
#include "hapticcal/report/results_json.hpp"

namespace hapticcal {
namespace {

// The samples of one run: desired and measured force, and the moment.
std::string force_csv(const ForceRun& run) {
  std::string out = "t,Fd_x,Fd_y,Fd_z,F_x,F_y,F_z,M_x,M_y,M_z\n";
  for (size_t k = 0; k < run.t.size(); ++k) {
    const auto& d = run.desired[k];
    const auto& m = run.measured[k];
    out += fmt::format("{},{},{},{},{},{},{},{},{},{}\n", run.t[k], d[0], d[1], d[2], m[0], m[1],
                       m[2], m[3], m[4], m[5]);
  }
  return out;
}

// A model file: a URDF with the request's chain, a device file as it is; a
// tree is refused (the force study is of one tool point).
DeviceModel load_force_model(const ForceRequest& request, const std::string& path) {
  DeviceModel model =
      is_urdf_path(path) ? load_model(path, request.tip, request.root) : load_model(path);
  if (model.tree())
    throw InputError(path, 0, "--tip", "force: a tree has several tips; give one chain (--tip)");
  return model;
}

}  // namespace

ForceJob run_force_job(const ForceRequest& request) {
  if (!request.tip.empty() || !request.root.empty()) {
    bool urdf = false;
    for (const std::string* p : {&request.actual, &request.nominal, &request.calibrated})
      urdf = urdf || is_urdf_path(*p);
    if (!urdf) {
      throw InputError(fmt::format("{}: applies to URDF models (.urdf); none is given",
                                   request.tip.empty() ? "--root" : "--tip"));
    }
  }
  ForceJob job;
  job.actual = load_force_model(request, request.actual);
  const DeviceModel nominal = load_force_model(request, request.nominal);
  const DeviceModel calibrated = load_force_model(request, request.calibrated);
  ForceScenario sc = request.scenario;
  if (request.lock) sc.locked_joint = *request.lock - 1;  // 0 -> kNoLock
  sc.locked_joint = resolved_locked_joint(sc, job.actual);
  job.out = std::make_unique<OutputSet>(request.out, "force");
  if (request.posture) {
    sc.posture = Eigen::Map<const Eigen::VectorXd>(
        request.posture->data(), static_cast<Eigen::Index>(request.posture->size()));
  }
  job.gain_limit = force_study_gain_limit(job.actual, nominal, calibrated, sc);
  if (!(std::abs(sc.gain) < job.gain_limit)) {
    throw InputError(fmt::format(
        "--gain {} is outside the stable range: |G| < {:.4f} for these models (1 / spectral radius "
        "of the rendering map)",
        sc.gain, job.gain_limit));
  }
  job.study = run_force_study(job.actual, nominal, calibrated, sc);
  const std::string& dir = job.out->dir();
  write_file_atomically(dir + "/force_nominal.csv", force_csv(job.study.nominal));
  write_file_atomically(dir + "/force_calibrated.csv", force_csv(job.study.calibrated));
  job.results_json =
      force_json(request.actual, request.nominal, request.calibrated, job.study, job.gain_limit);
  write_file_atomically(dir + "/results.json", job.results_json);
  Report report = force_report(job.study.nominal, job.study.calibrated);
  report.outcome = force_outcome(job.study);
  job.figures = write_report(report, dir, job.report_note);
  job.out->commit();
  return job;
}

ConvertJob run_convert_job(const ConvertRequest& given) {
  ConvertRequest request = given;
  request.in = resolve_model_path(given.in);  // a built-in device's name: its file
  for (const std::string* path : {&request.in, &request.out}) {
    if (!is_urdf_path(*path) && !is_yaml_path(*path)) {
      throw InputError(
          fmt::format("convert: '{}' is neither a device file (.yaml, .yml) nor a URDF (.urdf)",
                      printable(*path, 200)));
    }
  }
  ConvertJob job;
  job.to_urdf = is_urdf_path(request.out);
  if (is_urdf_path(request.in) == job.to_urdf) {
    throw InputError(fmt::format("convert: {} and {} are both {}: nothing to convert",
                                 printable(request.in, 200), printable(request.out, 200),
                                 job.to_urdf ? "URDF" : "device files"));
  }
  job.model = load_model(request.in, request.tip, request.root);
  if (job.to_urdf) {
    if (job.model.tree())
      throw InputError(request.in, 0, "tips",
                       "a tree of several tips: convert writes one chain's URDF (calibrate from "
                       "the tree's URDF writes its calibrated.urdf)");
    for (const Link& l : job.model.links) {
      if (!l.transmission.is_none()) job.with_transmission.push_back(l.name);
    }
    DeviceModel without = job.model;  // its parts besides the transmissions
    for (Link& l : without.links) l.transmission = Transmission();
    job.families_left_out = not_in_urdf(without);
    write_file_atomically(request.out, device_to_urdf(job.model));
  } else {
    save_device(job.model, request.out);
  }
  return job;
}

}  // namespace hapticcal
