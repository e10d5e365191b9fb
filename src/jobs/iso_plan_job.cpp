// plan --iso9283 as one job (jobs/iso_plan_job.hpp).
#include "hapticcal/jobs/iso_plan_job.hpp"

#include <fmt/format.h>

#include <nlohmann/json.hpp>

#include "hapticcal/core/files.hpp"
#include "hapticcal/model/frame.hpp"
#include "hapticcal/model_io/model_source.hpp"
#include "hapticcal/report/iso9283_report.hpp"
#include "hapticcal/report/report.hpp"

namespace hapticcal {
namespace {

// How the cube was found (iso9283.json's "search").
nlohmann::ordered_json iso_search_json(const IsoCubeSearch& s) {
  return {{"centre", s.centre_given ? "given" : "searched over the workspace"},
          {"size", s.size_given ? "given" : "the largest that fits"},
          {"candidates", s.candidates},
          {"moves", s.moves},
          {"seed", s.seed},
          {"stopped", s.stopped},
          {"fits",
           "the five poses reached within the joint limits away from singularities "
           "(smallest singular value of the Jacobian by the readings at least " +
               fmt::format("{:g}", kIsoAwayFromSingular) +
               " m/rad, rotation at 0.1 m/rad), the eight corners within reach"},
          {"text", iso_search_text(s)}};
}

// plan.csv: a row a pose visited, cycle after cycle in the plan's order.
std::string plan_csv(const DeviceModel& model, const IsoCubePlan& plan) {
  std::string csv;
  for (int i = 1; i <= model.dof(); ++i) csv += fmt::format("q{},", i);
  csv += "point\n";
  for (int cycle = 0; cycle < plan.cycles; ++cycle) {
    for (int k : plan.order) {
      const IsoTestPose& p = plan.poses[static_cast<size_t>(k)];
      for (int i = 0; i < model.dof(); ++i) csv += fmt::format("{:.17g},", p.readings[i]);
      csv += p.label + "\n";
    }
  }
  return csv;
}

std::string plan_json(const std::string& model_path, const IsoCubePlan& plan) {
  nlohmann::ordered_json poses = nlohmann::ordered_json::array();
  for (const IsoTestPose& p : plan.poses) {
    const Eigen::Vector3d rpy = matrix_rpy(p.pose.R);
    poses.push_back({{"pose", p.label},
                     {"xyz", {p.pose.p.x(), p.pose.p.y(), p.pose.p.z()}},
                     {"rpy", {rpy[0], rpy[1], rpy[2]}},
                     {"readings", std::vector<double>(p.readings.data(),
                                                      p.readings.data() + p.readings.size())}});
  }
  nlohmann::ordered_json corners = nlohmann::ordered_json::array();
  for (const Eigen::Vector3d& c : plan.corners) corners.push_back({c.x(), c.y(), c.z()});
  const nlohmann::ordered_json json = {
      {"format", "hapticcal-iso9283-plan/1"},
      {"model", model_path},
      {"centre", {plan.centre.x(), plan.centre.y(), plan.centre.z()}},
      {"size", plan.size},
      {"plane", "C1-C2-C7-C8"},
      {"corners", corners},
      {"orientation_held", plan.orientation_held},
      {"search", iso_search_json(plan.search)},
      {"cycles", plan.cycles},
      {"order", {"P1", "P5", "P4", "P3", "P2"}},
      {"poses", poses}};
  return json.dump(2);
}

std::vector<std::string> plan_lines(const DeviceModel& model, const IsoCubePlan& plan) {
  std::vector<std::string> lines;
  lines.push_back(fmt::format("hapticcal plan --iso9283: {} ({} joints)", model.name, model.dof()));
  lines.push_back(fmt::format(
      "  test cube: edge {:.1f} mm about ({:.1f}, {:.1f}, {:.1f}) mm, its edges along the base "
      "frame's axes; measuring plane C1-C2-C7-C8",
      plan.size * 1e3, plan.centre.x() * 1e3, plan.centre.y() * 1e3, plan.centre.z() * 1e3));
  lines.push_back("  " + iso_search_text(plan.search));
  for (const IsoTestPose& p : plan.poses) {
    lines.push_back(fmt::format("  {}: ({:9.3f}, {:9.3f}, {:9.3f}) mm", p.label, p.pose.p.x() * 1e3,
                                p.pose.p.y() * 1e3, p.pose.p.z() * 1e3));
  }
  lines.push_back(fmt::format("  {}; {} cycles of P1, P5, P4, P3, P2 ({} rows)",
                              plan.orientation_held
                                  ? "every pose at the centre's orientation"
                                  : "orientation not held (fewer than six joints)",
                              plan.cycles, plan.cycles * 5));
  return lines;
}

}  // namespace

IsoPlanJob run_iso_plan_job(const IsoPlanRequest& request, const std::string& out) {
  IsoPlanJob job;
  job.model = load_model(request.model, request.tip, request.root);
  IsoCubeOptions cube;
  if (request.cube_centre) {
    const auto& c = *request.cube_centre;
    cube.centre = Eigen::Vector3d(c[0], c[1], c[2]);
  }
  if (request.cube_size > 0) cube.size = request.cube_size;
  cube.cycles = request.cycles;
  job.out = std::make_unique<OutputSet>(out, "plan");
  job.plan = plan_iso_cube(job.model, cube);
  job.json = plan_json(request.model, job.plan);
  job.lines = plan_lines(job.model, job.plan);
  write_file_atomically(job.out->dir() + "/plan.csv", plan_csv(job.model, job.plan));
  write_file_atomically(job.out->dir() + "/iso9283.json", job.json + "\n");
  job.figures = write_report(iso_plan_report(job.model, job.plan), job.out->dir(), job.report_note);
  job.out->commit();
  return job;
}

}  // namespace hapticcal
