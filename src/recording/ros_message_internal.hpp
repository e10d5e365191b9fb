// A message type as compiled from its definition text (ros_definitions.cpp
// parses, ros_message.cpp decodes): every type it uses resolved to an index,
// with the bounds a decode checks before reading (the least bytes an element
// takes, the flattened entries it makes).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "hapticcal/recording/ros_message.hpp"

namespace hapticcal::recording::detail {

// The primitives as serialised. ROS 1's byte is int8 and char uint8; ROS 2's
// byte and char are both uint8. time and duration become small structs
// ({sec, nsec} in ROS 1, {sec, nanosec} in ROS 2), so no kind of their own.
enum class Kind : std::uint8_t {
  kBool,
  kInt8,
  kUint8,
  kInt16,
  kUint16,
  kInt32,
  kUint32,
  kInt64,
  kUint64,
  kFloat32,
  kFloat64,
  kString,
  kMessage,
};

enum class ArrayKind : std::uint8_t { kNone, kFixed, kSequence };

struct CompiledField {
  std::string name;
  Kind kind = Kind::kUint8;
  ArrayKind array = ArrayKind::kNone;
  std::uint32_t count = 0;              // kFixed: the element count
  std::int64_t bound = -1;              // kSequence: T[<=N]'s N, -1 when unbounded
  std::int64_t string_bound = -1;       // string<=N's N, -1 when unbounded
  std::int32_t type = -1;               // kMessage: index in CompiledType::structs
  bool hidden = false;                  // ROS 2's placeholder byte of an empty message
  std::uint64_t min_element_bytes = 0;  // the least bytes one element takes
  std::uint64_t element_weight = 1;     // flattened entries one element makes
};

struct CompiledStruct {
  std::string name;  // "package/Type"
  std::vector<CompiledField> fields;
  std::uint64_t min_bytes = 0;  // saturating
  std::uint64_t weight = 0;     // flattened entries outside arrays (saturating)
  int height = 1;               // levels of nesting, this one included
};

class CompiledType final : public MessageType {
 public:
  CompiledType(std::string name, Encoding encoding)
      : MessageType(std::move(name)), encoding(encoding) {}
  Encoding encoding;
  std::vector<CompiledStruct> structs;  // [0] is the message itself
};

constexpr int kMaxNesting = 64;
constexpr std::uint64_t kSaturated = std::uint64_t{1} << 62;

inline std::uint64_t saturating_add(std::uint64_t a, std::uint64_t b) {
  return a + b > kSaturated ? kSaturated : a + b;
}
inline std::uint64_t saturating_mul(std::uint64_t a, std::uint64_t b) {
  if (a == 0 || b == 0) return 0;
  return a > kSaturated / b ? kSaturated : a * b;
}

}  // namespace hapticcal::recording::detail
