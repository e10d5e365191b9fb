// How a driver publishes a device's joints, and the readings the device's file
// wants: reading_i = sum_k c_ik position[name_k] + offset_i (import --convention).
// Each convention cites the driver's source for every coefficient.
#pragma once

#include <string>
#include <vector>

namespace hapticcal::recording {

class Convention {
 public:
  struct Term {
    std::string joint;  // the published joint's name
    double coefficient = 1;
  };
  struct Reading {
    std::string name;  // the device file's joint
    std::vector<Term> terms;
    double offset = 0;  // rad
  };

  Convention(std::string name, std::string device, std::string source,
             std::vector<Reading> readings)
      : name_(std::move(name)),
        device_(std::move(device)),
        source_(std::move(source)),
        readings_(std::move(readings)) {}

  const std::string& name() const { return name_; }
  const std::string& device() const { return device_; }  // the built-in device it serves
  std::size_t readings() const { return readings_.size(); }
  std::vector<std::string> reading_names() const;
  // Finds each term's joint among a topic's `names`: InputError naming the
  // topic (`what`) and the missing joint otherwise.
  void bind(const std::vector<std::string>& names, const std::string& what);
  // After bind: the positions (in the topic's order) the readings use, sorted.
  std::vector<int> positions_used() const;
  // The readings of one message's positions (in the topic's order).
  void readings_of(const double* positions, std::vector<double>& out) const;
  // One line for the terminal: the convention, its device and source.
  std::string note() const;

 private:
  std::string name_, device_, source_;
  std::vector<Reading> readings_;
  std::vector<std::vector<int>> index_;  // bind's: each term's position in the topic
};

// The conventions hapticcal knows, by name.
std::vector<Convention> conventions();
// The one named `name`; InputError listing the known ones otherwise.
Convention convention_named(const std::string& name);

}  // namespace hapticcal::recording
