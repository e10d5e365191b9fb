// Decoding a message from its compiled definition (ros_definitions.cpp).
//
// ROS 1 serialisation
// (http://wiki.ros.org/ROS/Technical%20Overview#Message_serialization_and_msg_MD5_sums,
// http://wiki.ros.org/msg): little-endian, no padding; a string is a uint32
// length and its bytes; a variable array a uint32 count and its elements; a
// fixed array its elements only; time and duration two 32-bit integers.
// ROS 2 (https://design.ros2.org/articles/generated_interfaces_cpp.html and
// OMG CDR, https://www.omg.org/spec/DDS-XTypes/1.3, 7.4.3 "XCDR1" as
// rmw_fastrtps writes it): a 4-byte encapsulation header (0x00 0x01 little
// endian, 0x00 0x00 big endian, then two option bytes), each primitive aligned
// to its size counted from the byte after the header; a string is a uint32
// length including the terminating NUL, the bytes and the NUL; a sequence a
// uint32 count then its elements (aligned only when there are any); up to 3
// bytes of padding may end the message.
#include <fmt/format.h>

#include <charconv>
#include <cstring>
#include <functional>
#include <type_traits>

#include "hapticcal/core/error.hpp"
#include "recording/ros_message_internal.hpp"

namespace hapticcal::recording {

namespace {

using detail::ArrayKind;
using detail::CompiledField;
using detail::CompiledStruct;
using detail::CompiledType;
using detail::Kind;

constexpr std::size_t kCdrHeaderBytes = 4;

std::size_t primitive_bytes(Kind kind) {
  switch (kind) {
    case Kind::kInt16:
    case Kind::kUint16:
      return 2;
    case Kind::kInt32:
    case Kind::kUint32:
    case Kind::kFloat32:
      return 4;
    case Kind::kInt64:
    case Kind::kUint64:
    case Kind::kFloat64:
      return 8;
    default:
      return 1;
  }
}

const char* kind_name(Kind kind) {
  constexpr const char* names[] = {"bool",    "int8",   "uint8",  "int16",  "uint16",
                                   "int32",   "uint32", "int64",  "uint64", "float32",
                                   "float64", "string", "message"};
  return names[static_cast<int>(kind)];
}

class Decoder {
 public:
  Decoder(const CompiledType& type, std::string_view data, const std::string& origin,
          std::size_t max_elements)
      : type_(type),
        data_(reinterpret_cast<const unsigned char*>(data.data())),
        size_(data.size()),
        origin_(origin),
        budget_(max_elements),
        max_elements_(max_elements) {}

  DecodedMessage run() {
    const bool cdr = type_.encoding == Encoding::kCdr;
    if (cdr) read_encapsulation();
    const CompiledStruct& root = type_.structs[0];
    if (root.weight > budget_)
      fail(fmt::format(
          "the message has {} entries without its arrays' elements, more than the bound of {}",
          root.weight, max_elements_));
    budget_ -= root.weight;
    path_.reserve(128);
    decode_struct(root);
    const std::size_t left = size_ - pos_;
    if (left > (cdr ? 3u : 0u)) {
      path_.clear();
      fail(fmt::format(
          "{} bytes left over after the message{} (the definition does not match the data)", left,
          cdr ? ", more than CDR's padding of at most 3" : ""));
    }
    return std::move(out_);
  }

 private:
  [[noreturn]] void fail(const std::string& what) const {
    throw InputError(fmt::format("{}: {}{}{} (at byte {} of {})", origin_, path_,
                                 path_.empty() ? "" : ": ", what, pos_, size_));
  }

  void read_encapsulation() {
    if (size_ < kCdrHeaderBytes)
      fail(fmt::format("{} bytes: no room for CDR's 4-byte encapsulation header", size_));
    const unsigned kind = (unsigned{data_[0]} << 8) | data_[1];
    if (kind > 1)
      fail(
          fmt::format("CDR encapsulation kind 0x{:04x} is not supported: only plain CDR (XCDR1), "
                      "0x0000 big endian and 0x0001 little endian",
                      kind));
    swap_ = kind == 0;
    pos_ = kCdrHeaderBytes;
    align_origin_ = kCdrHeaderBytes;
    cdr_ = true;
  }

  // n elements of `weight` entries each, against what is left of max_elements.
  void charge(std::uint64_t n, std::uint64_t weight) {
    if (weight != 0 && n > budget_ / weight)
      fail(
          fmt::format("{} elements ({} entries each) exceed what is left of the bound of {} "
                      "entries in a message",
                      n, weight, max_elements_));
    budget_ -= n * weight;
  }

  void align(std::size_t n) {
    if (!cdr_) return;
    const std::size_t pad = (n - (pos_ - align_origin_) % n) % n;
    if (pad > size_ - pos_)
      fail(fmt::format("the message ends within the padding before a {}-byte value", n));
    pos_ += pad;
  }

  template <typename T>
  T raw(Kind kind) {
    if (sizeof(T) > size_ - pos_)
      fail(fmt::format("the message ends: {} needs {} bytes, {} left", kind_name(kind), sizeof(T),
                       size_ - pos_));
    T value;
    std::memcpy(&value, data_ + pos_, sizeof(T));
    pos_ += sizeof(T);
    if constexpr (sizeof(T) == 2) {
      if (swap_) value = static_cast<T>(__builtin_bswap16(static_cast<std::uint16_t>(value)));
    } else if constexpr (sizeof(T) == 4) {
      if (swap_) value = static_cast<T>(__builtin_bswap32(static_cast<std::uint32_t>(value)));
    } else if constexpr (sizeof(T) == 8) {
      if (swap_) value = static_cast<T>(__builtin_bswap64(static_cast<std::uint64_t>(value)));
    }
    return value;
  }

  std::uint32_t read_length() {
    align(4);
    return raw<std::uint32_t>(Kind::kUint32);
  }

  // A 64-bit integer as a double only while every integer is one (|v| <= 2^53).
  template <typename T>
  double exact(T value) {
    constexpr auto kLimit = std::uint64_t{1} << 53;
    const bool negative = std::is_signed_v<T> && value < 0;
    const std::uint64_t magnitude = negative ? std::uint64_t{0} - static_cast<std::uint64_t>(value)
                                             : static_cast<std::uint64_t>(value);
    if (magnitude > kLimit) {
      pos_ -= sizeof(T);
      fail(fmt::format("{} is beyond 2^53, where a double no longer holds every integer", value));
    }
    return static_cast<double>(value);
  }

  // One number; the caller has aligned the cursor.
  double number(Kind kind) {
    switch (kind) {
      case Kind::kBool: {
        const std::uint8_t b = raw<std::uint8_t>(kind);
        if (b > 1) {
          --pos_;
          fail(fmt::format("bool byte {} is neither 0 nor 1", b));
        }
        return b;
      }
      case Kind::kInt8:
        return raw<std::int8_t>(kind);
      case Kind::kUint8:
        return raw<std::uint8_t>(kind);
      case Kind::kInt16:
        return raw<std::int16_t>(kind);
      case Kind::kUint16:
        return raw<std::uint16_t>(kind);
      case Kind::kInt32:
        return raw<std::int32_t>(kind);
      case Kind::kUint32:
        return raw<std::uint32_t>(kind);
      case Kind::kInt64:
        return exact(raw<std::int64_t>(kind));
      case Kind::kUint64:
        return exact(raw<std::uint64_t>(kind));
      case Kind::kFloat32: {
        const std::uint32_t bits = raw<std::uint32_t>(kind);
        float f;
        std::memcpy(&f, &bits, sizeof f);
        return f;
      }
      case Kind::kFloat64: {
        const std::uint64_t bits = raw<std::uint64_t>(kind);
        double d;
        std::memcpy(&d, &bits, sizeof d);
        return d;
      }
      default:
        break;
    }
    fail("not a number");  // unreachable: strings and messages are decoded elsewhere
  }

  void string(const CompiledField& f) {
    const std::uint32_t length = read_length();
    const std::size_t left = size_ - pos_;
    if (length > left)
      fail(fmt::format("a string of {} bytes claimed, {} bytes left", length, left));
    std::size_t text_bytes = length;
    if (cdr_ && length > 0) {
      if (data_[pos_ + length - 1] != 0)
        fail(fmt::format("a CDR string of {} bytes does not end in NUL", length));
      --text_bytes;  // CDR's length counts the NUL
    }
    if (f.string_bound >= 0 && text_bytes > static_cast<std::uint64_t>(f.string_bound))
      fail(fmt::format("a string of {} bytes, more than its bound string<={}", text_bytes,
                       f.string_bound));
    out_.strings.emplace_back(path_,
                              std::string(reinterpret_cast<const char*>(data_ + pos_), text_bytes));
    pos_ += length;
  }

  void element(const CompiledField& f) {
    if (f.kind == Kind::kMessage) {
      decode_struct(type_.structs[static_cast<std::size_t>(f.type)]);
    } else if (f.kind == Kind::kString) {
      string(f);
    } else {
      align(primitive_bytes(f.kind));
      const double value = number(f.kind);
      if (!f.hidden) out_.numbers.emplace_back(path_, value);
    }
  }

  void array(const CompiledField& f) {
    std::uint64_t count = f.count;
    if (f.array == ArrayKind::kSequence) {
      count = read_length();
      if (f.bound >= 0 && count > static_cast<std::uint64_t>(f.bound))
        fail(fmt::format("{} elements, more than its bound [<={}]", count, f.bound));
    }
    if (count == 0) return;
    const bool primitive = f.kind != Kind::kMessage && f.kind != Kind::kString;
    check_count(count, f.min_element_bytes);  // before alignment, whose padding may not be there
    if (primitive) {
      align(primitive_bytes(f.kind));
      check_count(count, f.min_element_bytes);
    }
    charge(count, f.element_weight);
    const std::size_t base = path_.size();
    char digits[16];
    for (std::uint64_t i = 0; i < count; ++i) {
      path_.resize(base);
      path_ += '[';
      const auto end = std::to_chars(digits, digits + sizeof digits, i).ptr;
      path_.append(digits, end);
      path_ += ']';
      if (primitive) {
        const double value = number(f.kind);  // contiguous: aligned once above
        out_.numbers.emplace_back(path_, value);
      } else {
        element(f);
      }
    }
    path_.resize(base);
  }

  void check_count(std::uint64_t count, std::uint64_t min_element_bytes) const {
    const std::size_t left = size_ - pos_;
    if (min_element_bytes > 0 && count > left / min_element_bytes)
      fail(fmt::format("{} elements claimed, {} bytes left", count, left));
  }

  void decode_struct(const CompiledStruct& s) {
    for (const CompiledField& f : s.fields) {
      const std::size_t base = path_.size();
      if (base != 0) path_ += '.';
      path_ += f.name;
      if (f.array == ArrayKind::kNone)
        element(f);
      else
        array(f);
      path_.resize(base);
    }
  }

  const CompiledType& type_;
  const unsigned char* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
  std::size_t align_origin_ = 0;
  bool cdr_ = false;
  bool swap_ = false;
  const std::string& origin_;
  std::uint64_t budget_;
  std::uint64_t max_elements_;
  std::string path_;
  DecodedMessage out_;
};

}  // namespace

namespace {

// Below this many entries a linear scan is as fast as hashing the path.
constexpr std::size_t kIndexedFrom = 16;

// The entry of `entries` at `path`: a scan for a few entries, else through
// `index`, (re)built when it does not cover every entry.
template <class Entries>
const typename Entries::value_type* find_path(const Entries& entries,
                                              DecodedMessage::PathIndex& index,
                                              std::string_view path) {
  if (entries.size() < kIndexedFrom) {
    for (const auto& entry : entries)
      if (entry.first == path) return &entry;
    return nullptr;
  }
  const std::hash<std::string_view> hash;
  if (index.entries != entries.size()) {
    std::size_t slots = 1;
    while (slots < 2 * entries.size()) slots *= 2;
    index.slots.assign(slots, 0);
    for (std::size_t i = 0; i < entries.size(); ++i) {
      std::size_t k = hash(entries[i].first) & (slots - 1);
      while (index.slots[k] != 0) k = (k + 1) & (slots - 1);
      index.slots[k] = static_cast<std::uint32_t>(i + 1);
    }
    index.entries = entries.size();
  }
  const std::size_t mask = index.slots.size() - 1;
  for (std::size_t k = hash(path) & mask; index.slots[k] != 0; k = (k + 1) & mask) {
    const auto& entry = entries[index.slots[k] - 1];
    if (entry.first == path) return &entry;
  }
  return nullptr;
}

}  // namespace

const double* DecodedMessage::number(std::string_view path) const {
  const auto* entry = find_path(numbers, number_index_, path);
  return entry == nullptr ? nullptr : &entry->second;
}

const std::string* DecodedMessage::string(std::string_view path) const {
  const auto* entry = find_path(strings, string_index_, path);
  return entry == nullptr ? nullptr : &entry->second;
}

DecodedMessage decode_message(const MessageType& type, std::string_view data,
                              const std::string& origin, std::size_t max_elements) {
  const auto* compiled = dynamic_cast<const CompiledType*>(&type);
  if (compiled == nullptr)
    throw std::logic_error("decode_message: a MessageType not made by MessageType::parse");
  return Decoder(*compiled, data, origin, max_elements).run();
}

}  // namespace hapticcal::recording
