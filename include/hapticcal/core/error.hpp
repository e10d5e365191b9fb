// Bad input is reported by exception, with where it was found.
#pragma once

#include <cstddef>
#include <stdexcept>
#include <string>
#include <vector>

namespace hapticcal {

// A file, log or argument that cannot be used. what() is one line:
// "FILE:LINE: KEY: message" (the parts that are known); any control character
// in them is written \xNN, so what() never holds a line break.
class InputError : public std::invalid_argument {
 public:
  InputError(const std::string& file, int line, const std::string& key, const std::string& message);
  explicit InputError(const std::string& message);

  const std::string& file() const { return file_; }
  int line() const { return line_; }
  const std::string& key() const { return key_; }
  const std::string& message() const { return message_; }

 private:
  std::string file_;
  int line_ = 0;
  std::string key_;
  std::string message_;
};

// Reading or writing failed for a reason outside the input (a full disk, a
// permission, a failed sync): what() is "PATH: what failed: the system's reason".
class IoError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// `text` as a message may quote it: at most its first `max_chars` characters
// (then "..."), every control character (C0, DEL, C1), backslash and byte that
// is not valid UTF-8 written as \xNN. Used wherever an InputError echoes input.
std::string printable(const std::string& text, std::size_t max_chars = 40);

// `text` in XML or HTML, as character data or a double-quoted attribute's
// value: & < > and " as their entities (a report's text, a URDF's names).
std::string markup_escaped(const std::string& text);

// `text` with every occurrence of `from` (not empty) replaced by `to`, left to
// right (a replacement is not searched again): a message reworded for its
// reader, e.g. a command-line option named as the scenario key that set it.
std::string replace_all(std::string text, const std::string& from, const std::string& to);

// Why `text` cannot be a name that reaches output (a device name, a column):
// empty when it is valid UTF-8 without control characters, else the reason,
// e.g. "control character \x0a at byte 4" or "invalid UTF-8 at byte 2".
std::string text_problem(const std::string& text);

// The Levenshtein distance between `a` and `b`: the fewest single-character
// insertions, deletions and substitutions that turn one into the other.
std::size_t edit_distance(const std::string& a, const std::string& b);

// For an unknown `name`: " (did you mean 'NAME'?)" with the closest of `known`
// by edit distance when it is close (at most 2 edits, or a third of the
// name's length), else empty. Ties go to the first in `known`.
std::string did_you_mean(const std::string& name, const std::vector<std::string>& known);

}  // namespace hapticcal
