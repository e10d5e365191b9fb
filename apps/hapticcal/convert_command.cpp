// `hapticcal convert`: a device file to URDF or a URDF to a device file.
#include <fmt/format.h>

#include <string>

#include "commands.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/jobs/force_job.hpp"
#include "hapticcal/model_io/device.hpp"
#include "hapticcal/model_io/model_source.hpp"
#include "hapticcal/model_io/urdf.hpp"
#include "terminal.hpp"

namespace hapticcal::cli {

CLI::App* add_convert_command(CLI::App& app, ConvertOptions& o) {
  auto* convert = app.add_subcommand(
      "convert", "Convert a device file (.yaml, .yml) to URDF (.urdf) or a URDF to a device file");
  o.bound.bind(convert, hapticcal::convert_options());
  convert->footer(
      "Examples:\n"
      "  hapticcal convert examples/meca500/meca500.yaml meca500.urdf\n"
      "  hapticcal convert robot.urdf robot.yaml --tip tool0 --root base_link");
  return convert;
}

// Device file -> URDF or URDF -> device file, by the file names' extensions.
int run_convert(const ConvertOptions& o) {
  hapticcal::ConvertRequest request;
  o.bound.apply(request);
  const hapticcal::ConvertJob job = hapticcal::run_convert_job(request);
  if (job.to_urdf) {
    if (!job.with_transmission.empty()) {
      std::string links;
      for (const std::string& name : job.with_transmission)
        links += (links.empty() ? "" : ", ") + name;
      hapticcal::cli::say(
          stderr,
          "hapticcal: warning: URDF cannot express transmissions: those of {} are only "
          "XML comments in {}\n",
          links, request.out);
    }
    if (!job.families_left_out.empty()) {
      hapticcal::cli::say(
          stderr,
          "hapticcal: warning: URDF cannot express the {} of {}: {} is the model without it (XML "
          "comments hold it), not a model fitted without it; calibrate from a URDF writes "
          "calibrated.urdf, the geometry fitted alone\n",
          job.families_left_out, request.in, request.out);
    }
    fmt::print("wrote {} ({}, {} joints; its chain is hapticcal_measurement -> tool)\n",
               request.out, job.model.name, job.model.dof());
  } else {
    std::string names;
    for (const hapticcal::Link& l : job.model.links) names += (names.empty() ? "" : " ") + l.name;
    fmt::print("wrote {} ({}, {} joints: {})\n", request.out, job.model.name, job.model.dof(),
               names);
  }
  return 0;
}

CLI::App* add_devices_command(CLI::App& app) {
  auto* devices =
      app.add_subcommand("devices",
                         "List the built-in devices: each name works wherever a model file "
                         "does (--model NAME, convert NAME out.urdf)");
  devices->footer(
      "Examples:\n"
      "  hapticcal devices\n"
      "  hapticcal convert geomagic-touch touch.urdf");
  return devices;
}

int run_devices() {
  for (const hapticcal::BuiltinDevice& d : hapticcal::builtin_devices()) {
    const hapticcal::DeviceModel m = hapticcal::load_device(d.path);
    fmt::print("{:<22} {} joints  {}\n{:<22} {}\n", d.name, m.dof(), d.description, "", d.path);
  }
  return 0;
}

}  // namespace hapticcal::cli
