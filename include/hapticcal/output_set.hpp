// A command's output folder written as one set (issue 10): every file goes into
// a fresh staging folder beside --out, which takes --out's place in one atomic
// rename when the run is complete. So a reader sees the old set or the new one,
// never a mix; an interrupted, failed or refused run leaves the old set as it was.
#pragma once

#include <string>

namespace hapticcal {

// The name of the marker file every set holds (the command that wrote it). A
// folder is replaced only if it is empty, holds this marker or a results.json:
// a rerun never deletes a folder of someone else's files.
inline constexpr const char* kOutputMarker = ".hapticcal-output";

class OutputSet {
 public:
  // Checks --out before any work: refuses an empty path, a file, the working
  // folder or one of its ancestors, and a folder of foreign files (InputError);
  // creates --out if missing and locks it, refusing a second run into the same
  // folder while this one holds it, and creates the staging folder (IoError
  // when either fails, with the system's reason). `command` goes into the marker.
  OutputSet(const std::string& out, const std::string& command);
  // Removes the staging folder unless committed.
  ~OutputSet();
  OutputSet(const OutputSet&) = delete;
  OutputSet& operator=(const OutputSet&) = delete;

  // The staging folder: write every output here.
  const std::string& dir() const { return staging_; }
  // --out as given.
  const std::string& target() const { return target_; }
  // Copies `name` from the current --out into the staging folder if it is there
  // (a previous good model kept beside a failed run's results). Whether it was.
  bool keep_previous(const std::string& name) const;
  // Puts the staging folder in --out's place (atomic exchange), then removes
  // the old set. IoError if the exchange fails; the old set is then unchanged.
  void commit();

 private:
  std::string target_, staging_;
  int lock_fd_ = -1;
  bool committed_ = false;
  bool created_ = false;  // --out did not exist before this run
};

// Blocks SIGINT, SIGTERM and SIGHUP in the calling thread (and the threads it
// starts later) and starts a thread that waits for them: on one, it removes
// every staging folder of an uncommitted OutputSet and exits with 128 + signal.
// Call once at the start of main, before any other thread exists.
void remove_staging_on_signals();
// If that thread is handling a signal, waits for it to end the process (so
// that main neither returns nor reports the errors the interrupt caused).
void finish_if_interrupted();

}  // namespace hapticcal
