// `import` as a job (jobs/import_job.hpp): the recording layer makes the files,
// the job owns the output set they go into.
#include "hapticcal/jobs/import_job.hpp"

#include <optional>
#include <string>

#include "hapticcal/core/files.hpp"
#include "hapticcal/core/output_set.hpp"

namespace hapticcal {

recording::ImportResult run_import(const recording::ImportRequest& request) {
  const std::string folder = request.out.empty() ? recording::kDefaultImportOut : request.out;
  std::optional<OutputSet> out;  // none for a listing, which writes nothing
  if (!request.list) out.emplace(folder, "import");
  recording::ImportResult result =
      recording::import_recording(request, [&](const std::string& name, const std::string& text) {
        write_file_atomically(out.value().dir() + "/" + name, text);
      });
  if (!out) return result;
  OutputSet& set = *out;
  write_file_atomically(set.dir() + "/import.json",
                        recording::import_summary_json(request, result));
  set.commit();
  result.written = set.written();
  result.out = set.target();
  return result;
}

}  // namespace hapticcal
