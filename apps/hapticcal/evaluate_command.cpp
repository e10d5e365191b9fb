// `hapticcal evaluate`: a model's errors on a log, optionally against a
// reference model and after fitting the measurement frame (--register).
#include <fmt/format.h>

#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include "commands.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/core/output_set.hpp"
#include "hapticcal/data_io/fixture.hpp"
#include "hapticcal/report/report.hpp"
#include "hapticcal/report/results_json.hpp"
#include "hapticcal/study/evaluate.hpp"
#include "output_summary.hpp"
#include "terminal.hpp"

namespace hapticcal::cli {

CLI::App* add_evaluate_command(CLI::App& app, EvaluateOptions& o) {
  auto* evaluate = app.add_subcommand("evaluate", "RMS and max error of a model on a log");
  evaluate->add_option("--model", o.model, "Device file (YAML) or URDF (.urdf)")->required();
  add_chain_options(evaluate, o.chain);
  evaluate->add_option("--log", o.log, "Measurement log (CSV)")->required();
  evaluate->add_flag("--json", o.json,
                     "Print one JSON object (metres); writes no files unless --out is given");
  evaluate->add_option("--out", o.out,
                       "Output directory: report.html, results.json (default "
                       "hapticcal-out/evaluate)");
  evaluate->add_option("--point-distance", o.point_distance,
                       "A known distance between two fixture points: A:B=METRES (repeatable)");
  evaluate->add_option("--fixture", o.fixture,
                       "Fixture file (YAML): known positions (points) and distances of the log's "
                       "fixture points");
  evaluate->add_option("--reference", o.reference,
                       "A second device file (e.g. the nominal one): adds the paper's eq. 9 "
                       "improvement of --model over it on the same log");
  evaluate->add_option("--columns", o.columns,
                       "Column names of a log without header, comma separated, _ skips one "
                       "(e.g. q1[deg],q2[deg],x,y,z,_)");
  evaluate->add_option("--register", o.register_what,
                       "frame or frame,tool: fit the measurement frame (the base pose), and the "
                       "tool point, on this log before scoring (a tracker moved since); each "
                       "model on its own with --reference");
  return evaluate;
}

int run_evaluate(const EvaluateOptions& o) {
  o.chain.check_used({o.model, o.reference});
  std::optional<hapticcal::RegisterWhat> registration;
  if (o.register_given) registration = hapticcal::parse_register(o.register_what);
  const hapticcal::DeviceModel model = o.chain.load(o.model);
  const hapticcal::Log log = hapticcal::read_log(
      o.log, o.columns.empty() ? std::vector<std::string>{} : hapticcal::split_columns(o.columns));
  const hapticcal::Fixture known = hapticcal::fixture_facts(o.fixture, o.point_distance);
  std::optional<hapticcal::EvaluationComparison> cmp;
  if (!o.reference.empty()) {
    cmp = hapticcal::compare_to_reference(model, o.chain.load(o.reference), log, known.distances,
                                          known.points, registration);
  }
  const hapticcal::Evaluation ev =
      cmp ? cmp->model
          : (registration ? hapticcal::evaluate_registered(model, log, *registration,
                                                           known.distances, known.points)
                          : hapticcal::evaluate(model, log, known.distances, known.points));
  const std::optional<hapticcal::Evaluation> ref =
      cmp ? std::optional<hapticcal::Evaluation>(cmp->reference) : std::nullopt;
  const std::string json = hapticcal::evaluation_json(cmp ? &*cmp : nullptr, ev);
  const std::vector<std::string> lines =
      hapticcal::evaluation_lines(cmp ? &*cmp : nullptr, ev, o.reference);
  if (o.json) {
    fmt::print("{}\n", json);
    if (!o.out_given) return 0;
  } else {
    fmt::print("model: {} ({}, {} joints)\n", o.model, model.name, model.dof());
    fmt::print("log:   {} ({} rows)\n", o.log, ev.n);
    for (const std::string& line : lines) fmt::print("{}\n", line);
  }
  hapticcal::OutputSet out(o.out, "evaluate");
  hapticcal::write_file_atomically(out.dir() + "/results.json", json + "\n");
  const std::string reported =
      report(hapticcal::evaluation_report(model, o.model, log, ev, ref ? &*ref : nullptr,
                                          o.reference, lines),
             out.dir(), o.out);
  out.commit();
  // With --json, stdout is the JSON object alone.
  std::FILE* said = o.json ? stderr : stdout;
  hapticcal::cli::say(said, "{}", reported);
  hapticcal::cli::say(said, "{}", hapticcal::cli::output_summary(out, o.out));
  return 0;
}

}  // namespace hapticcal::cli
