// Decoding ROS messages from their definitions: the ROS 1 serialisation and
// ROS 2's CDR, for any message whose definition is known (the recording's own,
// or the built-in definitions of the standard types hapticcal imports). A
// message decodes to its fields flattened by path ("header.stamp.sec",
// "position[2]", "transforms[0].child_frame_id"); numbers as double (64-bit
// integers beyond 2^53 are an error, never rounded silently), strings as
// text. Every problem is an InputError naming the origin ("bag.bag: byte 4120:
// /joint_states (sensor_msgs/JointState): position: 3 elements claimed, 8 bytes left").
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "hapticcal/recording/recording.hpp"

namespace hapticcal::recording {

// The standard types' definitions (ROS 1 text; for CDR the same fields with
// ROS 2's Header: builtin_interfaces/Time stamp {int32 sec, uint32 nanosec},
// string frame_id, no seq): sensor_msgs/JointState, geometry_msgs/PoseStamped,
// PointStamped, TransformStamped, tf2_msgs/TFMessage and what they contain.
// Empty for another type. Used when a recording holds no definition.
std::string builtin_definition(const std::string& type, Encoding encoding);

// A message type compiled from its definition text (the main type's fields,
// then "====...\nMSG: package/Type" sections for the types it uses; comments,
// constants and default values allowed; bounded and fixed arrays, bounded
// strings, time and duration, every ROS primitive). InputError naming `origin`
// for a type it uses but does not define, a recursive type, or more than 64
// levels of nesting.
class MessageType {
 public:
  static std::shared_ptr<const MessageType> parse(const std::string& type,
                                                  const std::string& definition, Encoding encoding,
                                                  const std::string& origin);
  virtual ~MessageType() = default;
  const std::string& name() const { return name_; }

 protected:
  explicit MessageType(std::string name) : name_(std::move(name)) {}

 private:
  std::string name_;
};

// One message's fields, flattened in the order of the definition.
struct DecodedMessage {
  std::vector<std::pair<std::string, double>> numbers;
  std::vector<std::pair<std::string, std::string>> strings;

  // The number at `path`, or nullptr. A look-up takes constant time whatever the
  // message's size (a JointState of 100,000 joints is read field by field): a
  // message of more than a few entries is indexed by path at its first look-up
  // (again when entries are added; a path changed in place is not seen).
  const double* number(std::string_view path) const;
  const std::string* string(std::string_view path) const;

  // Open addressing over the entries' positions (position + 1; 0 is empty).
  struct PathIndex {
    std::vector<std::uint32_t> slots;
    std::size_t entries = 0;  // how many entries the slots index
  };

 private:
  mutable PathIndex number_index_, string_index_;
};

// Decodes `data` as `type`. An array may hold at most `max_elements` elements
// in all (the flattened message's size bound). InputError naming `origin` when
// the bytes end early, a length exceeds what is left, or bytes are left over.
DecodedMessage decode_message(const MessageType& type, std::string_view data,
                              const std::string& origin, std::size_t max_elements = 1u << 20);

}  // namespace hapticcal::recording
