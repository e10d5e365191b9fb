// The XML side of a URDF: the text's shape, checked before
// tinyxml and urdfdom read it, and a small scanner of our own that locates the
// elements in the text, for line numbers, for the origins exactly as written,
// and for the textual edit of calibrated_urdf.
#include <fmt/format.h>
#include <tinyxml.h>

#include <algorithm>
#include <charconv>
#include <optional>
#include <string_view>

#include "hapticcal/core/error.hpp"
#include "model_io/urdf_internal.hpp"

namespace hapticcal::detail {
namespace {

// ---------------------------------------------------------------------------
// Where the elements are in the text.

void append_utf8(std::string& out, unsigned long cp) {
  if (cp < 0x80) {
    out += static_cast<char>(cp);
  } else if (cp < 0x800) {
    out += static_cast<char>(0xc0 | (cp >> 6));
    out += static_cast<char>(0x80 | (cp & 0x3f));
  } else if (cp < 0x10000) {
    out += static_cast<char>(0xe0 | (cp >> 12));
    out += static_cast<char>(0x80 | ((cp >> 6) & 0x3f));
    out += static_cast<char>(0x80 | (cp & 0x3f));
  } else {
    out += static_cast<char>(0xf0 | (cp >> 18));
    out += static_cast<char>(0x80 | ((cp >> 12) & 0x3f));
    out += static_cast<char>(0x80 | ((cp >> 6) & 0x3f));
    out += static_cast<char>(0x80 | (cp & 0x3f));
  }
}

// The five predefined entities and character references; anything else as is.
// The longest reference is "&#x10FFFF;": its ';' is looked for that far only,
// so that a text of '&' without ';' is decoded in linear time.
constexpr size_t kLongestEntity = 10;

std::string decode_entities(std::string_view raw) {
  std::string out;
  for (size_t i = 0; i < raw.size();) {
    const size_t semi = raw[i] == '&'
                            ? raw.substr(0, std::min(raw.size(), i + kLongestEntity)).find(';', i)
                            : std::string_view::npos;
    if (semi == std::string_view::npos) {
      out += raw[i++];
      continue;
    }
    const std::string_view entity = raw.substr(i + 1, semi - i - 1);
    static const std::pair<std::string_view, char> kNamed[] = {
        {"lt", '<'}, {"gt", '>'}, {"amp", '&'}, {"quot", '"'}, {"apos", '\''}};
    bool done = false;
    for (const auto& [name, ch] : kNamed) {
      if (entity == name) {
        out += ch;
        done = true;
      }
    }
    if (!done && entity.size() > 1 && entity[0] == '#') {
      const bool hex = entity[1] == 'x' || entity[1] == 'X';
      const std::string_view digits = entity.substr(hex ? 2 : 1);
      unsigned long cp = 0;
      const auto [end, ec] =
          std::from_chars(digits.data(), digits.data() + digits.size(), cp, hex ? 16 : 10);
      if (ec == std::errc() && end == digits.data() + digits.size() && cp > 0 && cp <= 0x10ffff) {
        append_utf8(out, cp);
        done = true;
      }
    }
    if (!done) out.append(raw.substr(i, semi - i + 1));
    i = semi + 1;
  }
  return out;
}

// How a processing instruction or declaration ends: as XML says (`?>`; a
// DOCTYPE's `>` outside its brackets and quotes), or at its first `>`, as
// tinyxml 2.6 reads both: the shape check must never skip more of the text
// than the parser reads (a DOCTYPE "[>" then 100,000 nested elements would
// reach tinyxml's recursion unchecked).
enum class MarkupEnd { kXml, kFirstGreaterThan };

// Markup that is not an element, at t[i] == '<': a comment, a CDATA section, a
// processing instruction or a declaration. Returns the position just past it
// (npos if it does not end), or nothing if t[i] starts an element or an end tag.
std::optional<size_t> past_markup(const std::string& t, size_t i, MarkupEnd end_at) {
  auto past = [&](size_t from, std::string_view end) {
    const size_t k = t.find(end, from);
    return k == std::string::npos ? k : k + end.size();
  };
  if (t.compare(i, 4, "<!--") == 0) return past(i + 4, "-->");
  if (t.compare(i, 9, "<![CDATA[") == 0) return past(i + 9, "]]>");
  const bool instruction = t.compare(i, 2, "<?") == 0;
  if (!instruction && t.compare(i, 2, "<!") != 0) return std::nullopt;
  if (end_at == MarkupEnd::kFirstGreaterThan) return past(i + 2, ">");
  if (instruction) return past(i + 2, "?>");
  int brackets = 0;
  char quote = 0;
  for (size_t k = i + 2; k < t.size(); ++k) {
    const char c = t[k];
    if (quote) {
      if (c == quote) quote = 0;
    } else if (c == '"' || c == '\'') {
      quote = c;
    } else if (c == '[') {
      ++brackets;
    } else if (c == ']') {
      --brackets;
    } else if (c == '>' && brackets <= 0) {
      return k + 1;
    }
  }
  return std::string::npos;
}

// Every element of a well-formed document (tinyxml has accepted it), in document
// order. InputError in the unlikely case that this reading of the text fails.
std::vector<XmlElement> scan_elements(const std::string& t, const std::string& origin) {
  std::vector<XmlElement> out;
  std::vector<int> open;
  size_t counted = 0;
  int line = 1;
  auto line_at = [&](size_t pos) {
    line += static_cast<int>(std::count(t.begin() + counted, t.begin() + pos, '\n'));
    counted = pos;
    return line;
  };
  auto fail = [&](size_t pos) {
    throw InputError(origin, line_at(std::min(pos, t.size())), "",
                     "cannot locate the XML elements of the text");
  };
  const size_t n = t.size();
  size_t i = 0;
  while ((i = t.find('<', i)) != std::string::npos) {
    if (const std::optional<size_t> end = past_markup(t, i, MarkupEnd::kXml)) {
      if (*end == std::string::npos) fail(i);
      i = *end;
    } else if (t.compare(i, 2, "</") == 0) {
      const size_t close = t.find('>', i);
      if (close == std::string::npos || open.empty()) fail(i);
      out[open.back()].end = close + 1;
      open.pop_back();
      i = close + 1;
    } else {
      XmlElement e;
      e.begin = i;
      e.line = line_at(i);
      e.parent = open.empty() ? -1 : open.back();
      size_t k = i + 1;
      while (k < n && !is_blank(t[k]) && t[k] != '/' && t[k] != '>') ++k;
      e.name = t.substr(i + 1, k - i - 1);
      e.attributes_end = k;
      for (;;) {
        while (k < n && is_blank(t[k])) ++k;
        if (k >= n) fail(i);
        if (t[k] == '/') {
          if (k + 1 >= n || t[k + 1] != '>') fail(k);
          e.empty = true;
          e.tag_end = e.end = k + 2;
          break;
        }
        if (t[k] == '>') {
          e.tag_end = k + 1;
          break;
        }
        const size_t a = k;
        while (k < n && !is_blank(t[k]) && t[k] != '=' && t[k] != '>' && t[k] != '/') ++k;
        XmlAttribute attr;
        attr.name = t.substr(a, k - a);
        while (k < n && is_blank(t[k])) ++k;
        if (k >= n || t[k] != '=') fail(k);
        ++k;
        while (k < n && is_blank(t[k])) ++k;
        if (k >= n || (t[k] != '"' && t[k] != '\'')) fail(k);
        const size_t close = t.find(t[k], k + 1);
        if (close == std::string::npos) fail(k);
        attr.value_begin = k + 1;
        attr.value_end = close;
        attr.value = decode_entities(std::string_view(t).substr(k + 1, close - k - 1));
        e.attributes.push_back(std::move(attr));
        k = close + 1;
        e.attributes_end = k;
      }
      i = e.tag_end;
      out.push_back(std::move(e));
      if (!out.back().empty) open.push_back(static_cast<int>(out.size()) - 1);
    }
  }
  if (!open.empty()) fail(n);
  return out;
}

// ---------------------------------------------------------------------------
// The shape of the text, before tinyxml reads it.

// tinyxml parses nested elements by recursion and checks each attribute against
// the element's others: bounds far above any URDF (which nests 4 levels and has
// at most a handful of attributes) keep its stack and time small.
constexpr int kMaxXmlDepth = 200;
constexpr int kMaxXmlAttributes = 100;

// Nesting depth and attributes per element, in one pass before tinyxml sees the
// text; a malformed text is left to tinyxml's message.
void check_xml_shape(const std::string& t, const std::string& origin) {
  const size_t n = t.size();
  int depth = 0;
  size_t i = 0;
  auto line_at = [&](size_t pos) {
    return static_cast<int>(std::count(t.begin(), t.begin() + static_cast<long>(pos), '\n')) + 1;
  };
  while (i < n && (i = t.find('<', i)) != std::string::npos) {
    if (const std::optional<size_t> end = past_markup(t, i, MarkupEnd::kFirstGreaterThan)) {
      i = std::min(*end, n);  // unterminated: tinyxml says so
    } else if (t.compare(i, 2, "</") == 0) {
      --depth;
      const size_t close = t.find('>', i + 2);
      i = close == std::string::npos ? n : close + 1;
    } else {
      const size_t start = i;
      int attributes = 0;
      char quote = 0;
      size_t k = i + 1;
      for (; k < n; ++k) {
        const char c = t[k];
        if (quote) {
          if (c == quote) quote = 0;
        } else if (c == '"' || c == '\'') {
          quote = c;
        } else if (c == '=') {
          ++attributes;
        } else if (c == '>') {
          break;
        }
      }
      if (k >= n) return;  // unterminated: tinyxml says so
      if (attributes > kMaxXmlAttributes) {
        throw InputError(origin, line_at(start), "",
                         fmt::format("XML: an element with {} attributes: at most {}", attributes,
                                     kMaxXmlAttributes));
      }
      if (t[k - 1] != '/' && ++depth > kMaxXmlDepth) {
        throw InputError(origin, line_at(start), "",
                         fmt::format("XML: elements nested more than {} deep", kMaxXmlDepth));
      }
      i = k + 1;
    }
  }
}

}  // namespace

Document locate(const std::string& text, const std::string& origin) {
  Document doc;
  doc.elements = scan_elements(text, origin);
  for (size_t k = 0; k < doc.elements.size(); ++k) {
    const XmlElement& e = doc.elements[k];
    if (doc.robot < 0 && e.parent < 0 && e.name == "robot") doc.robot = static_cast<int>(k);
    if (doc.robot < 0 || e.parent != doc.robot) continue;
    const XmlAttribute* name = e.attribute("name");
    if (!name) continue;
    if (e.name == "joint") doc.joints.emplace(name->value, static_cast<int>(k));
    if (e.name == "link") doc.links.emplace(name->value, static_cast<int>(k));
  }
  return doc;
}

// NUL bytes, nesting and attributes beyond the bounds, and malformed XML, with
// tinyxml's line (urdfdom gives none).
void check_xml(const std::string& text, const std::string& origin) {
  if (const size_t nul = text.find('\0'); nul != std::string::npos) {
    const int line = static_cast<int>(std::count(text.begin(), text.begin() + nul, '\n')) + 1;
    throw InputError(origin, line, "", fmt::format("NUL byte at byte {}", nul));
  }
  check_xml_shape(text, origin);
  // A xacro file (macros, ${...} expressions) read as URDF would fail deep in
  // urdfdom ("Unable to parse component [${d1}]"): said plainly instead.
  for (const char* mark : {"xmlns:xacro", "<xacro:"}) {
    if (const size_t at = text.find(mark); at != std::string::npos) {
      const int line = static_cast<int>(std::count(text.begin(), text.begin() + at, '\n')) + 1;
      throw InputError(origin, line, "",
                       "a xacro file (its macros and ${...} expressions are not URDF): expand it "
                       "with xacro first (xacro robot.urdf.xacro > robot.urdf)");
    }
  }
  // tinyxml 2.6 steps over a UTF-8 sequence by its lead byte, past the end of a
  // text that ends in a cut one: NUL bytes after the text stop it there.
  const std::string padded = text + std::string(4, '\0');
  TiXmlDocument xml;
  xml.Parse(padded.c_str(), nullptr, TIXML_ENCODING_UTF8);
  if (xml.Error()) {
    throw InputError(origin, std::max(0, xml.ErrorRow()), "",
                     fmt::format("XML: {}", printable(xml.ErrorDesc(), 120)));
  }
}

}  // namespace hapticcal::detail
