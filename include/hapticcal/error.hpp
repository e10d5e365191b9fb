// Bad input is reported by exception, with where it was found.
#pragma once

#include <stdexcept>
#include <string>

namespace hapticcal {

// A file, log or argument that cannot be used. what() is one line:
// "FILE:LINE: KEY: message" (the parts that are known).
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

}  // namespace hapticcal
