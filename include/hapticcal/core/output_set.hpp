// A command's output folder written as one set (issue 10): every file goes into
// a fresh staging folder beside --out, which takes --out's place in one atomic
// rename when the run is complete. So a reader sees the old set or the new one,
// never a mix; an interrupted, failed or refused run leaves the old set as it was.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace hapticcal {

// The name of the marker file every set holds: the command that wrote it, then
// every entry of the set. A folder is replaced only if it is empty or holds
// this marker and nothing it does not list: a rerun never deletes files it did
// not write.
inline constexpr const char* kOutputMarker = ".hapticcal-output";
// In a staging folder while a run writes it: the stale-staging sweep removes
// only folders that carry it (a user's ".results.tmp-mine/" is not a run's).
inline constexpr const char* kStagingMarker = ".hapticcal-staging";

class OutputSet {
 public:
  // Checks --out before any work: refuses an empty path, a file, the working
  // folder or one of its ancestors, a mount point and a folder holding files
  // no run wrote (InputError); a symbolic link is followed;
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
  // --out, symbolic links resolved: the folder that is replaced.
  const std::string& target() const { return target_; }
  // The command that wrote the set now in --out ("calibrate"...), or empty.
  std::string previous_command() const;
  // Copies `name` from the current --out into the staging folder if it is there
  // (a previous good model kept beside a failed run's results). Whether it was.
  bool keep_previous(const std::string& name) const;
  // Writes the marker, puts the staging folder in --out's place (an atomic
  // exchange where the file system has one) and removes the old set. IoError
  // if that fails; the old set is then unchanged.
  void commit();
  // After commit(): whether --out held an earlier set, now replaced (not an
  // empty or new folder), and the command that had written it.
  bool replaced_previous() const { return !replaced_command_.empty(); }
  const std::string& replaced_command() const { return replaced_command_; }
  // After commit(): the set's entries, sorted, folders ending in '/'; the
  // marker is left out (it is bookkeeping, listed in no summary).
  const std::vector<std::string>& written() const { return written_; }

 private:
  // The constructor's second half (the lock, the staging folder), and its undo.
  void acquire(const std::filesystem::path& parent, const std::string& stem);
  void release();

  std::string shown_, command_;
  std::string target_, staging_;  // resolved paths
  std::string replaced_command_;  // "hapticcal simulate"... of the set commit() replaced
  std::vector<std::string> written_;
  int lock_fd_ = -1, staging_fd_ = -1;
  bool committed_ = false;
  bool kept_ = false;      // commit() refused: the staging folder is the user's to take
  bool created_ = false;   // --out was empty (or missing) when this run locked it
  bool exchange_ = false;  // the file system exchanges folders atomically
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
