// ROS 1 bags (format 2.0, http://wiki.ros.org/Bags/Format/2.0) written from
// scratch by the tests and benchmarks, and the ROS 1 serialisation of the
// messages hapticcal imports: inputs of any size (a JointState of 100,000
// joints) and any fault (a changed byte, a NaN) made in the test itself.
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <map>
#include <set>
#include <string>
#include <vector>

namespace hapticcal::testing {

inline std::string le32(std::uint32_t v) {
  return std::string(reinterpret_cast<const char*>(&v), 4);
}
inline std::string le64(std::uint64_t v) {
  return std::string(reinterpret_cast<const char*>(&v), 8);
}
inline std::string f64(double v) { return std::string(reinterpret_cast<const char*>(&v), 8); }

// ROS 1's serialisation of a string and of a Header {seq, stamp, frame_id}.
inline std::string ros1_string(const std::string& s) {
  return le32(static_cast<std::uint32_t>(s.size())) + s;
}
inline std::string ros1_time(std::int64_t ns) {
  return le32(static_cast<std::uint32_t>(ns / 1000000000)) +
         le32(static_cast<std::uint32_t>(ns % 1000000000));
}
inline std::string ros1_header(std::int64_t stamp_ns, const std::string& frame = "") {
  return le32(0) + ros1_time(stamp_ns) + ros1_string(frame);
}

// sensor_msgs/JointState: names and positions (no velocities or efforts).
inline std::string ros1_joint_state(std::int64_t stamp_ns, const std::vector<std::string>& names,
                                    const std::vector<double>& positions) {
  std::string out = ros1_header(stamp_ns) + le32(static_cast<std::uint32_t>(names.size()));
  for (const std::string& n : names) out += ros1_string(n);
  out += le32(static_cast<std::uint32_t>(positions.size()));
  for (const double p : positions) out += f64(p);
  return out + le32(0) + le32(0);
}

// geometry_msgs/PoseStamped: position p and orientation q (w, x, y, z).
inline std::string ros1_pose_stamped(std::int64_t stamp_ns, const double p[3], const double q[4]) {
  return ros1_header(stamp_ns, "tracker") + f64(p[0]) + f64(p[1]) + f64(p[2]) + f64(q[1]) +
         f64(q[2]) + f64(q[3]) + f64(q[0]);
}

// One geometry_msgs/TransformStamped of a tf2_msgs/TFMessage.
struct Transform {
  std::string parent, child;
  double p[3] = {0, 0, 0};
  double q[4] = {1, 0, 0, 0};  // w, x, y, z
};
inline std::string ros1_tf_message(std::int64_t stamp_ns, const std::vector<Transform>& ts) {
  std::string out = le32(static_cast<std::uint32_t>(ts.size()));
  for (const Transform& t : ts) {
    out += ros1_header(stamp_ns, t.parent) + ros1_string(t.child) + f64(t.p[0]) + f64(t.p[1]) +
           f64(t.p[2]) + f64(t.q[1]) + f64(t.q[2]) + f64(t.q[3]) + f64(t.q[0]);
  }
  return out;
}

// A bag of uncompressed chunks (a new chunk every `chunk_messages` messages),
// each followed by its index data; then the connections and chunk infos, as
// rosbag writes them. The messages are written in the order given.
class Ros1BagWriter {
 public:
  void connection(std::uint32_t id, const std::string& topic, const std::string& type,
                  const std::string& definition) {
    connections_[id] = {topic, field("topic", topic) + field("type", type) +
                                   field("md5sum", "0123456789abcdef0123456789abcdef") +
                                   field("message_definition", definition)};
  }
  void message(std::uint32_t conn, std::int64_t time_ns, std::string data) {
    messages_.push_back({conn, time_ns, std::move(data)});
  }

  std::string bytes(std::size_t chunk_messages = 1000) const {
    std::string body, index;
    const std::size_t chunk_count = (messages_.size() + chunk_messages - 1) / chunk_messages;
    const std::size_t header_bytes = 13 + bag_header(0, 0).size();
    for (std::size_t first = 0; first < messages_.size(); first += chunk_messages) {
      const std::size_t end = std::min(messages_.size(), first + chunk_messages);
      std::string contents;
      std::set<std::uint32_t> defined;
      std::map<std::uint32_t, std::vector<std::pair<std::int64_t, std::uint32_t>>> entries;
      for (std::size_t k = first; k < end; ++k) {
        const Message& m = messages_[k];
        if (defined.insert(m.conn).second) contents += connection_record(m.conn);
        entries[m.conn].push_back({m.time_ns, static_cast<std::uint32_t>(contents.size())});
        contents += record(
            op(2) + field("conn", le32(m.conn)) + field("time", ros1_time(m.time_ns)), m.data);
      }
      const std::uint64_t chunk_pos = header_bytes + body.size();
      body += record(op(5) + field("compression", "none") +
                         field("size", le32(static_cast<std::uint32_t>(contents.size()))),
                     contents);
      std::string counts;
      for (const auto& [conn, list] : entries) {
        std::string data;
        for (const auto& [time, offset] : list) data += ros1_time(time) + le32(offset);
        body += record(op(4) + field("ver", le32(1)) + field("conn", le32(conn)) +
                           field("count", le32(static_cast<std::uint32_t>(list.size()))),
                       data);
        counts += le32(conn) + le32(static_cast<std::uint32_t>(list.size()));
      }
      index += record(op(6) + field("ver", le32(1)) + field("chunk_pos", le64(chunk_pos)) +
                          field("start_time", ros1_time(messages_[first].time_ns)) +
                          field("end_time", ros1_time(messages_[end - 1].time_ns)) +
                          field("count", le32(static_cast<std::uint32_t>(entries.size()))),
                      counts);
    }
    std::string connections;
    for (const auto& [id, c] : connections_) connections += connection_record(id);
    const std::uint64_t index_pos = header_bytes + body.size();
    return "#ROSBAG V2.0\n" + bag_header(index_pos, chunk_count) + body + connections + index;
  }

 private:
  struct Message {
    std::uint32_t conn;
    std::int64_t time_ns;
    std::string data;
  };
  struct Connection {
    std::string topic, header_data;
  };

  static std::string field(const std::string& name, const std::string& value) {
    return le32(static_cast<std::uint32_t>(name.size() + 1 + value.size())) + name + "=" + value;
  }
  static std::string op(int code) { return field("op", std::string(1, static_cast<char>(code))); }
  static std::string record(const std::string& header, const std::string& data) {
    return le32(static_cast<std::uint32_t>(header.size())) + header +
           le32(static_cast<std::uint32_t>(data.size())) + data;
  }
  std::string connection_record(std::uint32_t id) const {
    const Connection& c = connections_.at(id);
    return record(op(7) + field("conn", le32(id)) + field("topic", c.topic), c.header_data);
  }
  std::string bag_header(std::uint64_t index_pos, std::size_t chunks) const {
    const std::string fields =
        op(3) + field("index_pos", le64(index_pos)) +
        field("conn_count", le32(static_cast<std::uint32_t>(connections_.size()))) +
        field("chunk_count", le32(static_cast<std::uint32_t>(chunks)));
    return record(fields, std::string(4096 - fields.size() - 8, ' '));  // rosbag pads to 4 KiB
  }

  std::map<std::uint32_t, Connection> connections_;
  std::vector<Message> messages_;
};

}  // namespace hapticcal::testing
