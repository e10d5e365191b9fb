// What the recording tests share: a visitor that keeps what a reader handed
// out (checking each channel comes once and before its messages), and the
// writers' hex back to bytes.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "hapticcal/recording/recording.hpp"

namespace hapticcal::testing {

// What a reader handed out, in order.
struct Seen : recording::RecordingVisitor {
  struct Message {
    std::uint32_t id;
    std::int64_t receive_ns;
    std::string data;
    std::uint64_t offset;
  };
  std::map<std::uint32_t, recording::Channel> channels;
  std::vector<Message> messages;

  void channel(std::uint32_t id, const recording::Channel& channel) override {
    EXPECT_TRUE(channels.emplace(id, channel).second) << "channel " << id << " handed out twice";
  }
  void message(std::uint32_t id, std::int64_t receive_ns, std::string_view data,
               std::uint64_t offset) override {
    EXPECT_EQ(channels.count(id), 1u) << "a message on channel " << id << " before the channel";
    messages.push_back({id, receive_ns, std::string(data), offset});
  }
};

// "0aff..." as its bytes.
inline std::string from_hex(const std::string& hex) {
  std::string out;
  for (std::size_t i = 0; i + 1 < hex.size(); i += 2)
    out += static_cast<char>(std::stoi(hex.substr(i, 2), nullptr, 16));
  return out;
}

}  // namespace hapticcal::testing
