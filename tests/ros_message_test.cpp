// ROS message decoding (recording/ros_message.hpp) against independent
// writers: Debian's genpy classes and a byte-by-byte struct writer for ROS 1
// (tests/writers/ros1_messages.py), Foxglove's rosmsg2-serialization for CDR
// (tests/writers/cdr_messages.js). Every number and string each writer put in
// is compared, by path and in order; the built-in definitions decode the same
// bytes as the definitions the writers carry. Malformed bytes and definitions
// end in an InputError naming the origin and the field.
#include "hapticcal/recording/ros_message.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <chrono>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "hapticcal/core/error.hpp"
#include "recording_visitor.hpp"
#include "run_cli.hpp"

namespace {

using hapticcal::testing::from_hex;

using hapticcal::InputError;
using hapticcal::recording::builtin_definition;
using hapticcal::recording::decode_message;
using hapticcal::recording::DecodedMessage;
using hapticcal::recording::Encoding;
using hapticcal::recording::MessageType;

struct Case {
  std::string name, type, definition, bytes;
  std::vector<std::pair<std::string, double>> numbers;
  std::vector<std::pair<std::string, std::string>> strings;
};

Case to_case(const nlohmann::json& j) {
  Case c;
  c.name = j.value("name", j.value("topic", std::string()));
  c.type = j.value("type", std::string());
  c.definition = j.value("definition", std::string());
  c.bytes = from_hex(j.contains("hex") ? j.at("hex").get<std::string>()
                                       : j.at("data").get<std::string>());
  for (const auto& n : j.at("numbers"))
    c.numbers.emplace_back(n.at(0).get<std::string>(), n.at(1).get<double>());
  for (const auto& s : j.at("strings"))
    c.strings.emplace_back(s.at(0).get<std::string>(), s.at(1).get<std::string>());
  return c;
}

nlohmann::json run_writer(const std::string& program, const std::vector<std::string>& args) {
  const auto result = hapticcal::testing::run_program(program, args);
  EXPECT_EQ(result.exit_code, 0) << program << " " << args.at(0) << ":\n" << result.err;
  return nlohmann::json::parse(result.out);
}

const std::vector<Case>& ros1_cases() {
  static const std::vector<Case> cases = [] {
    std::vector<Case> out;
    for (const auto& j : run_writer(HAPTICCAL_DEBIAN_PYTHON,
                                    {HAPTICCAL_SOURCE_DIR "/tests/writers/ros1_messages.py"}))
      out.push_back(to_case(j));
    return out;
  }();
  return cases;
}

const nlohmann::json& cdr_output() {
  static const nlohmann::json out =
      run_writer("/usr/bin/node",
                 {HAPTICCAL_SOURCE_DIR "/tests/writers/cdr_messages.js", HAPTICCAL_NODE_MODULES});
  return out;
}

const std::vector<Case>& cdr_cases() {
  static const std::vector<Case> cases = [] {
    std::vector<Case> out;
    for (const auto& j : cdr_output().at("cases")) out.push_back(to_case(j));
    return out;
  }();
  return cases;
}

const Case& find(const std::vector<Case>& cases, const std::string& name) {
  for (const Case& c : cases)
    if (c.name == name) return c;
  throw std::runtime_error("no case " + name);
}

void expect_fields(const DecodedMessage& m, const Case& c, const std::string& what) {
  ASSERT_EQ(m.numbers.size(), c.numbers.size()) << what;
  for (std::size_t i = 0; i < c.numbers.size(); ++i) {
    EXPECT_EQ(m.numbers[i].first, c.numbers[i].first) << what;
    EXPECT_EQ(m.numbers[i].second, c.numbers[i].second) << what << " " << c.numbers[i].first;
  }
  ASSERT_EQ(m.strings.size(), c.strings.size()) << what;
  for (std::size_t i = 0; i < c.strings.size(); ++i) {
    EXPECT_EQ(m.strings[i].first, c.strings[i].first) << what;
    EXPECT_EQ(m.strings[i].second, c.strings[i].second) << what << " " << c.strings[i].first;
  }
}

DecodedMessage decode(const std::string& type, const std::string& definition, Encoding encoding,
                      const std::string& bytes, std::size_t max_elements = 1u << 20) {
  const auto compiled =
      MessageType::parse(type, definition, encoding, "test.bag: /topic (" + type + ")");
  return decode_message(*compiled, bytes, "test.bag: byte 77: /topic (" + type + ")", max_elements);
}

// The InputError's message, or a failure when there is none (or another kind).
template <typename F>
std::string input_error(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  } catch (const std::exception& e) {
    ADD_FAILURE() << "not an InputError: " << e.what();
    return {};
  }
  ADD_FAILURE() << "no error";
  return {};
}

std::string ros1_u32(std::uint32_t v) { return std::string(reinterpret_cast<const char*>(&v), 4); }
const std::string kCdrLe("\x00\x01\x00\x00", 4);

const char* const kStandardTypes[] = {"joint_state", "pose_stamped", "point_stamped",
                                      "transform_stamped", "tf_message"};

TEST(Ros1Message, DecodesEveryFieldAsGenpyAndStructWroteThem) {
  ASSERT_EQ(ros1_cases().size(), 6u);
  for (const Case& c : ros1_cases())
    expect_fields(decode(c.type, c.definition, Encoding::kRos1, c.bytes), c, c.name);
}

TEST(Ros1Message, BuiltinDefinitionsDecodeAsGenpysFullText) {
  for (const char* name : kStandardTypes) {
    const Case& c = find(ros1_cases(), name);
    const std::string builtin = builtin_definition(c.type, Encoding::kRos1);
    ASSERT_FALSE(builtin.empty()) << c.type;
    expect_fields(decode(c.type, builtin, Encoding::kRos1, c.bytes), c,
                  std::string("builtin ") + name);
  }
  EXPECT_EQ(builtin_definition("sensor_msgs/Imu", Encoding::kRos1), "");
}

TEST(Ros1Message, ConstantsAndCommentsAreNotFields) {
  const Case& c = find(ros1_cases(), "custom_everything");
  const DecodedMessage m = decode(c.type, c.definition, Encoding::kRos1, c.bytes);
  EXPECT_EQ(m.number("FOO"), nullptr);
  EXPECT_EQ(m.string("GREETING"), nullptr);
  ASSERT_NE(m.string("s"), nullptr);
  EXPECT_EQ(*m.string("s"), "a string # with a hash");
  ASSERT_NE(m.number("t.nsec"), nullptr);
  EXPECT_EQ(*m.number("t.nsec"), 999999999);
  EXPECT_EQ(*m.number("d.sec"), -5);  // duration is signed
  EXPECT_EQ(*m.number("by"), -128);   // ROS 1's byte is int8
}

TEST(CdrMessage, DecodesEveryFieldAsFoxgloveWroteThem) {
  ASSERT_EQ(cdr_cases().size(), 7u);
  for (const Case& c : cdr_cases())
    expect_fields(decode(c.type, c.definition, Encoding::kCdr, c.bytes), c, c.name);
}

TEST(CdrMessage, BuiltinDefinitionsDecodeAsTheWritersDefinitions) {
  for (const char* name : kStandardTypes) {
    const Case& c = find(cdr_cases(), name);
    const std::string builtin = builtin_definition(c.type, Encoding::kCdr);
    ASSERT_NE(builtin.find("MSG: builtin_interfaces/Time"), std::string::npos) << c.type;
    expect_fields(decode(c.type, builtin, Encoding::kCdr, c.bytes), c,
                  std::string("builtin ") + name);
  }
}

TEST(CdrMessage, RecordingMessagesDecodeWithBuiltinDefinitions) {
  const auto& topics = cdr_output().at("topics");
  std::size_t decoded = 0;
  for (const auto& j : cdr_output().at("messages")) {
    const Case c = to_case(j);
    for (const auto& t : topics)
      if (t.at("name") == j.at("topic")) {
        const std::string type = t.at("type");
        expect_fields(
            decode(type, builtin_definition(type, Encoding::kCdr), Encoding::kCdr, c.bytes), c,
            c.name);
        ++decoded;
      }
  }
  EXPECT_EQ(decoded, 180u);
}

TEST(CdrMessage, PackageMsgTypeNamesAndMissingTimeSectionMeanTheSame) {
  const Case& c = find(cdr_cases(), "custom_everything");
  std::string text = c.definition;
  for (const auto& [from, to] : std::vector<std::pair<std::string, std::string>>{
           {"hapticcal_test/Sample[2]", "hapticcal_test/msg/Sample[2]"},
           {"MSG: hapticcal_test/Sample", "MSG: hapticcal_test/msg/Sample"},
           {"std_msgs/Header header", "std_msgs/msg/Header header"}}) {
    const std::size_t at = text.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    text.replace(at, from.size(), to);
  }
  expect_fields(decode("hapticcal_test/msg/Everything", text, Encoding::kCdr, c.bytes), c,
                "msg/ names");
  // builtin_interfaces/Time is ROS 2's own: a definition without its section still decodes.
  const Case& js = find(cdr_cases(), "joint_state");
  const std::string cut =
      js.definition.substr(0, js.definition.find("\n====", js.definition.find("MSG: std_msgs")));
  ASSERT_EQ(cut.find("builtin_interfaces/Time\n"), std::string::npos);
  expect_fields(decode(js.type, cut, Encoding::kCdr, js.bytes), js, "no Time section");
}

TEST(CdrMessage, UpToThreePaddingBytesEndAMessage) {
  const Case& c = find(cdr_cases(), "custom_everything");  // ends with a uint8
  for (std::size_t pad = 1; pad <= 3; ++pad)
    expect_fields(decode(c.type, c.definition, Encoding::kCdr, c.bytes + std::string(pad, '\0')), c,
                  "padded");
  const std::string e = input_error(
      [&] { decode(c.type, c.definition, Encoding::kCdr, c.bytes + std::string(4, '\0')); });
  EXPECT_NE(e.find("test.bag: byte 77: /topic (hapticcal_test/Everything): 4 bytes left over"),
            std::string::npos)
      << e;
}

// Every proper prefix of a message is an InputError naming the origin.
void expect_every_prefix_refused(const Case& c, Encoding encoding) {
  const auto type = MessageType::parse(c.type, c.definition, encoding, "def");
  for (std::size_t n = 0; n < c.bytes.size(); ++n) {
    const std::string e =
        input_error([&] { decode_message(*type, c.bytes.substr(0, n), "cut.bag: byte 9: /t"); });
    EXPECT_EQ(e.rfind("cut.bag: byte 9: /t: ", 0), 0u) << c.name << " cut at " << n << ": " << e;
  }
}

TEST(MalformedMessage, EveryTruncationIsAnInputError) {
  for (const char* name : {"joint_state", "tf_message", "custom_everything"}) {
    expect_every_prefix_refused(find(ros1_cases(), name), Encoding::kRos1);
    expect_every_prefix_refused(find(cdr_cases(), name), Encoding::kCdr);
  }
  expect_every_prefix_refused(find(cdr_cases(), "big_endian"), Encoding::kCdr);
  // A cut inside a string names the element: 25 bytes of header, the count,
  // "shoulder" and "upper_arm" with their lengths, then 2 of "elbow"'s 5 bytes.
  const Case& js = find(ros1_cases(), "joint_state");
  const std::string e =
      input_error([&] { decode(js.type, js.definition, Encoding::kRos1, js.bytes.substr(0, 60)); });
  EXPECT_NE(e.find("test.bag: byte 77: /topic (sensor_msgs/JointState): name[2]: a string of 5 "
                   "bytes claimed, 2 "
                   "bytes left (at byte 58 of 60)"),
            std::string::npos)
      << e;
  // A count larger than the bytes left names the array before reading it.
  const std::string count = input_error(
      [&] { decode(js.type, js.definition, Encoding::kRos1, js.bytes.substr(0, 120)); });
  EXPECT_NE(count.find("(sensor_msgs/JointState): position: 6 elements claimed, 21 bytes left"),
            std::string::npos)
      << count;
}

TEST(MalformedMessage, HugeCountsAreRefusedBeforeAnyAllocation) {
  const std::string huge = ros1_u32(0xffffffffu);
  for (const char* def : {"float64[] values", "string[] values",
                          "pkg/Empty[] values\n===\nMSG: pkg/Empty\n", "uint8[] values"}) {
    const std::string e =
        input_error([&] { decode("pkg/T", def, Encoding::kRos1, huge + "12345678"); });
    EXPECT_NE(e.find(": values: "), std::string::npos) << def << ": " << e;
    EXPECT_NE(e.find("4294967295 elements"), std::string::npos) << def << ": " << e;
  }
  // The same in CDR, after the encapsulation header.
  const std::string e =
      input_error([&] { decode("pkg/T", "float64[] values", Encoding::kCdr, kCdrLe + huge); });
  EXPECT_NE(e.find("values: 4294967295 elements claimed, 0 bytes left"), std::string::npos) << e;
  // A uint8[] image counts toward max_elements like any array.
  const std::string image = ros1_u32(100) + std::string(100, '\x7f');
  EXPECT_EQ(decode("pkg/T", "uint8[] image", Encoding::kRos1, image).numbers.size(), 100u);
  const std::string bound =
      input_error([&] { decode("pkg/T", "uint8[] image", Encoding::kRos1, image, 50); });
  EXPECT_NE(
      bound.find(
          "image: 100 elements (1 entries each) exceed what is left of the bound of 50 entries"),
      std::string::npos)
      << bound;
}

TEST(MalformedMessage, StringsPastTheEndBoundsAndNulAreRefused) {
  std::string e =
      input_error([&] { decode("pkg/T", "string s", Encoding::kRos1, ros1_u32(100) + "abcde"); });
  EXPECT_NE(e.find("/topic (pkg/T): s: a string of 100 bytes claimed, 5 bytes left"),
            std::string::npos)
      << e;
  e = input_error([&] {
    decode("pkg/T", "string<=3 s", Encoding::kCdr, kCdrLe + ros1_u32(5) + std::string("abcd\0", 5));
  });
  EXPECT_NE(e.find("s: a string of 4 bytes, more than its bound string<=3"), std::string::npos)
      << e;
  e = input_error(
      [&] { decode("pkg/T", "string s", Encoding::kCdr, kCdrLe + ros1_u32(4) + "abcd"); });
  EXPECT_NE(e.find("s: a CDR string of 4 bytes does not end in NUL"), std::string::npos) << e;
  e = input_error(
      [&] { decode("pkg/T", "int16[<=2] v", Encoding::kCdr, kCdrLe + ros1_u32(3) + "abcdef"); });
  EXPECT_NE(e.find("v: 3 elements, more than its bound [<=2]"), std::string::npos) << e;
  e = input_error(
      [&] { decode("pkg/T", "bool[] flags", Encoding::kRos1, ros1_u32(2) + "\x01\x02"); });
  EXPECT_NE(e.find("flags[1]: bool byte 2 is neither 0 nor 1"), std::string::npos) << e;
}

TEST(MalformedMessage, LeftoverBytesAndForeignEncapsulationsAreRefused) {
  const Case& c = find(ros1_cases(), "point_stamped");
  std::string e =
      input_error([&] { decode(c.type, c.definition, Encoding::kRos1, c.bytes + "x"); });
  EXPECT_NE(e.find("1 bytes left over after the message"), std::string::npos) << e;
  e = input_error(
      [&] { decode("pkg/T", "uint8 a", Encoding::kCdr, std::string("\x00\x07\x00\x00\x01", 5)); });
  EXPECT_NE(e.find("CDR encapsulation kind 0x0007 is not supported"), std::string::npos) << e;
  e = input_error([&] { decode("pkg/T", "uint8 a", Encoding::kCdr, std::string("\x00\x01", 2)); });
  EXPECT_NE(e.find("no room for CDR's 4-byte encapsulation header"), std::string::npos) << e;
}

TEST(MalformedMessage, IntegersBeyondTwoToThe53AreRefusedNotRounded) {
  std::uint64_t v = (std::uint64_t{1} << 53) + 1;
  const std::string bytes(reinterpret_cast<const char*>(&v), 8);
  const std::string e =
      input_error([&] { decode("pkg/T", "uint64 count", Encoding::kRos1, bytes); });
  EXPECT_NE(e.find("count: 9007199254740993 is beyond 2^53"), std::string::npos) << e;
  v = std::uint64_t{1} << 53;
  EXPECT_EQ(*decode("pkg/T", "uint64 count", Encoding::kRos1,
                    std::string(reinterpret_cast<const char*>(&v), 8))
                 .number("count"),
            9007199254740992.0);
  std::int64_t s = -(std::int64_t{1} << 60);
  const std::string neg = input_error([&] {
    decode("pkg/T", "int64 n", Encoding::kRos1, std::string(reinterpret_cast<const char*>(&s), 8));
  });
  EXPECT_NE(neg.find("n: -1152921504606846976 is beyond 2^53"), std::string::npos) << neg;
}

std::string definition_error(const std::string& definition, Encoding encoding = Encoding::kRos1) {
  return input_error([&] {
    MessageType::parse("pkg/Top", definition, encoding, "rec.mcap: channel 3 (pkg/Top)");
  });
}

std::string chain(int levels) {
  std::string text = "pkg/L1 next\n";
  for (int i = 1; i < levels; ++i)
    text += fmt::format("===\nMSG: pkg/L{}\n{}\n", i,
                        i + 1 < levels ? fmt::format("L{} next", i + 1) : "uint8 v");
  return text;
}

TEST(MalformedDefinition, UndefinedRecursiveDeepAndBadTypesAreNamed) {
  std::string e = definition_error("int32 a\nFoo foo\n");
  EXPECT_NE(e.find("rec.mcap: channel 3 (pkg/Top): definition of pkg/Top, line 2: field foo: type "
                   "pkg/Foo is not defined"),
            std::string::npos)
      << e;
  e = definition_error("Header header\n");  // ROS 1's Header is std_msgs/Header
  EXPECT_NE(e.find("type std_msgs/Header is not defined"), std::string::npos) << e;
  e = definition_error("A a\n===\nMSG: pkg/A\nB b\n===\nMSG: pkg/B\npkg/A[] back\n");
  EXPECT_NE(e.find("recursive definition: pkg/Top -> pkg/A -> pkg/B -> pkg/A"), std::string::npos)
      << e;
  e = definition_error("Top again\n");
  EXPECT_NE(e.find("recursive definition: pkg/Top -> pkg/Top"), std::string::npos) << e;
  e = definition_error(chain(70));
  EXPECT_NE(e.find("more than 64 levels of nesting: pkg/Top -> ... -> pkg/L64"), std::string::npos)
      << e;
  EXPECT_NO_THROW(MessageType::parse("pkg/Top", chain(64), Encoding::kRos1,
                                     "ok"));  // 64 levels, the top's included
  e = definition_error(chain(65));
  EXPECT_NE(e.find("more than 64 levels of nesting"), std::string::npos) << e;
  e = definition_error("flaot64 x\n");
  EXPECT_NE(
      e.find(
          "line 1: field x: 'flaot64' is neither a primitive nor a type defined here (pkg/flaot64) "
          "(did you mean 'float64'?)"),
      std::string::npos)
      << e;
  e = definition_error("wstring w\n", Encoding::kCdr);
  EXPECT_NE(e.find("field w: wstring (UTF-16, implementation-defined in CDR) is not supported"),
            std::string::npos)
      << e;
  EXPECT_NE(definition_error("float64 x 0.0\n").find("ROS 1 fields have no default value"),
            std::string::npos);
  EXPECT_NE(definition_error("float64[x] v\n").find("bad array length"), std::string::npos);
  EXPECT_NE(definition_error("float64[<=99999999999] v\n").find("bad array bound"),
            std::string::npos);
  EXPECT_NE(definition_error("int32 a\nint32 a\n").find("field a is defined twice"),
            std::string::npos);
  EXPECT_NE(definition_error("int32 a.b\n").find("'a.b' is not a field name"), std::string::npos);
  EXPECT_NE(definition_error("int32[] A=1\n").find("constants are primitives"), std::string::npos);
  EXPECT_NE(
      definition_error("int32 a\n===\nint32 b\n").find("must be followed by 'MSG: package/Type'"),
      std::string::npos);
  EXPECT_NE(definition_error("module pkg { struct Top { double x; }; };").find("line 1"),
            std::string::npos);
}

TEST(MalformedDefinition, ExponentialExpansionsAreBoundedAtDecode) {
  // Ten fields of ten fields of ... eight levels of empty messages: 10^8
  // entries from no bytes at all, refused before decoding any.
  std::string text;
  for (int level = 0; level < 8; ++level) {
    if (level > 0) text += fmt::format("===\nMSG: pkg/W{}\n", level);
    for (int k = 0; k < 10; ++k) text += fmt::format("W{} f{}\n", level + 1, k);
  }
  text += "===\nMSG: pkg/W8\n";
  const auto start = std::chrono::steady_clock::now();
  const std::string e = input_error([&] { decode("pkg/Top", text, Encoding::kRos1, ""); });
  EXPECT_NE(e.find("/topic (pkg/Top): the message has 111111110 entries without its arrays' "
                   "elements, more than "
                   "the bound of 1048576"),
            std::string::npos)
      << e;
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 1.0);
}

TEST(Performance, JointStateDecodesInMicroseconds) {
  for (const auto* cases : {&ros1_cases(), &cdr_cases()}) {
    const Case& c = find(*cases, "joint_state");
    const Encoding encoding = cases == &ros1_cases() ? Encoding::kRos1 : Encoding::kCdr;
    const auto type = MessageType::parse(c.type, c.definition, encoding, "perf");
    constexpr int kMessages = 20000;
    std::size_t fields = 0;
    const auto start = std::chrono::steady_clock::now();
    for (int i = 0; i < kMessages; ++i)
      fields += decode_message(*type, c.bytes, "perf").numbers.size();
    const double us =
        std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - start).count();
    EXPECT_EQ(fields, kMessages * c.numbers.size());
    std::printf("%s joint_state (6 joints): %.2f us a message\n",
                encoding == Encoding::kRos1 ? "ROS 1" : "CDR", us / kMessages);
    EXPECT_LT(us / kMessages,
              1000.0);  // about 1 us at -O2; the sanitizers' build is ~50 times slower
  }
}

}  // namespace
