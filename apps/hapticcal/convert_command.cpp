// `hapticcal convert`: a device file to URDF or a URDF to a device file.
#include <fmt/format.h>

#include <string>

#include "commands.hpp"
#include "hapticcal/core/files.hpp"
#include "hapticcal/model_io/device.hpp"
#include "hapticcal/model_io/urdf.hpp"
#include "terminal.hpp"

namespace hapticcal::cli {

CLI::App* add_convert_command(CLI::App& app, ConvertOptions& o) {
  auto* convert = app.add_subcommand(
      "convert", "Convert a device file (.yaml, .yml) to URDF (.urdf) or a URDF to a device file");
  convert->add_option("IN", o.in, "Model to read")->required();
  convert->add_option("OUT", o.out, "File to write (replaced atomically)")->required();
  add_chain_options(convert, o.chain);
  return convert;
}

// Device file -> URDF or URDF -> device file, by the file names' extensions.
int run_convert(const ConvertOptions& o) {
  for (const std::string* path : {&o.in, &o.out}) {
    if (!hapticcal::is_urdf_path(*path) && !hapticcal::is_yaml_path(*path)) {
      hapticcal::cli::say(
          stderr,
          "hapticcal: convert: '{}' is neither a device file (.yaml, .yml) nor a URDF "
          "(.urdf)\n",
          hapticcal::printable(*path, 200));
      return kExitBadInput;
    }
  }
  const bool to_urdf = hapticcal::is_urdf_path(o.out);
  if (hapticcal::is_urdf_path(o.in) == to_urdf) {
    hapticcal::cli::say(stderr, "hapticcal: convert: {} and {} are both {}: nothing to convert\n",
                        hapticcal::printable(o.in, 200), hapticcal::printable(o.out, 200),
                        to_urdf ? "URDF" : "device files");
    return kExitBadInput;
  }
  const hapticcal::DeviceModel model = hapticcal::load_model(o.in, o.chain.tip, o.chain.root);
  if (to_urdf) {
    std::string with_transmission;
    for (const hapticcal::Link& l : model.links) {
      if (!l.transmission.is_none())
        with_transmission += (with_transmission.empty() ? "" : ", ") + l.name;
    }
    hapticcal::write_file_atomically(o.out, hapticcal::device_to_urdf(model));
    if (!with_transmission.empty()) {
      hapticcal::cli::say(
          stderr,
          "hapticcal: warning: URDF cannot express transmissions: those of {} are only "
          "XML comments in {}\n",
          with_transmission, o.out);
    }
    fmt::print("wrote {} ({}, {} joints; its chain is hapticcal_measurement -> tool)\n", o.out,
               model.name, model.dof());
  } else {
    hapticcal::save_device(model, o.out);
    fmt::print("wrote {} ({}, {} joints: {})\n", o.out, model.name, model.dof(), [&] {
      std::string names;
      for (const hapticcal::Link& l : model.links) names += (names.empty() ? "" : " ") + l.name;
      return names;
    }());
  }
  return 0;
}

}  // namespace hapticcal::cli
