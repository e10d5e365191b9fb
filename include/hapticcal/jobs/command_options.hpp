// A command's options in one place. Each option names its keyword (the command
// line's --flag, '_' written '-'), what it takes, its help, its range or words,
// the default both front ends show, and how a given value goes into the
// command's request. The command line (apps/hapticcal/bound_options.hpp) and
// the Python module (python/bound_command.hpp) both bind a command from its
// table, so an option, its default, its range and its help are written once.
#pragma once

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

#include "hapticcal/core/error.hpp"
#include "hapticcal/core/option_ranges.hpp"
#include "hapticcal/data_io/log.hpp"

namespace hapticcal {

// A flag, a whole number, a real number, a text, or a list of texts (the
// command line's repeated or comma-separated option; Python's list of texts,
// or the same comma-separated text).
enum class OptionKind { kFlag, kWhole, kNumber, kText, kList };
using OptionValue = std::variant<bool, long long, double, std::string, std::vector<std::string>>;

// A whole number's range with no upper limit but the type's (a seed).
inline constexpr OptionRange kAtLeastZero{0, std::numeric_limits<double>::infinity()};

template <class Request>
struct CommandOption {
  std::string name;  // the keyword: clock_search is --clock-search
  OptionKind kind = OptionKind::kText;
  std::string help;
  std::optional<OptionRange> range;  // a number's
  std::vector<std::string> words;    // a text's only words (none: any text)
  bool numbers = false;              // a text of comma-separated numbers (Python: or a list)
  bool required = false;             // Python: a positional parameter, in the table's order
  bool positional = false;           // Python: positional though not required (after those)
  bool argument = false;             // the command line's positional argument (NAME), no --flag
  bool negated = false;              // a flag on unless --no-<name> (Python: name=False)
  std::string needs;                 // the option it needs (clock_search: tracker)
  std::optional<OptionValue> shown;  // its default as both show it (none: not given)
  // Reads a given value into the request; a bad one is an InputError naming
  // the option as `as` (the command line's --flag or Python's keyword).
  std::function<void(Request&, const OptionValue&, const std::string& as)> set;

  std::string flag() const {
    std::string dashed = name;
    std::replace(dashed.begin(), dashed.end(), '_', '-');
    if (argument) {
      std::transform(dashed.begin(), dashed.end(), dashed.begin(),
                     [](unsigned char c) { return static_cast<char>(std::toupper(c)); });
      return dashed;
    }
    return (negated ? "--no-" : "--") + dashed;
  }
};

// A command's options, in the order its help lists them.
template <class Request>
using CommandOptions = std::vector<CommandOption<Request>>;

namespace option_detail {

template <class T>
struct Unwrapped {
  using type = T;
};
template <class T>
struct Unwrapped<std::optional<T>> {
  using type = T;
};

template <class T>
constexpr OptionKind kind_of() {
  if constexpr (std::is_same_v<T, bool>) {
    return OptionKind::kFlag;
  } else if constexpr (std::is_integral_v<T>) {
    return OptionKind::kWhole;
  } else if constexpr (std::is_floating_point_v<T>) {
    return OptionKind::kNumber;
  } else if constexpr (std::is_same_v<T, std::string>) {
    return OptionKind::kText;
  } else {
    static_assert(std::is_same_v<T, std::vector<std::string>>, "not an option's type");
    return OptionKind::kList;
  }
}

template <class T>
OptionValue to_value(const T& v) {
  if constexpr (std::is_same_v<T, bool>) {
    return v;
  } else if constexpr (std::is_integral_v<T>) {
    return static_cast<long long>(v);
  } else if constexpr (std::is_floating_point_v<T>) {
    return static_cast<double>(v);
  } else {
    return v;
  }
}

template <class T>
T from_value(const OptionValue& v) {
  if constexpr (std::is_same_v<T, bool>) {
    return std::get<bool>(v);
  } else if constexpr (std::is_integral_v<T>) {
    return static_cast<T>(std::get<long long>(v));
  } else if constexpr (std::is_floating_point_v<T>) {
    return static_cast<T>(std::get<double>(v));
  } else {
    return std::get<T>(v);
  }
}

}  // namespace option_detail

// An option held in a field of the request (`field(request)` returns it). Its
// kind follows the field's type, and the default it shows is the field's value
// in a default-constructed request (an empty optional, text or list shows none).
template <class Request, class Field>
CommandOption<Request> field_option(std::string name, std::string help, Field field,
                                    std::optional<OptionRange> range = {}) {
  using Stored = std::remove_cvref_t<decltype(field(std::declval<Request&>()))>;
  using T = typename option_detail::Unwrapped<Stored>::type;
  CommandOption<Request> o;
  o.name = std::move(name);
  o.kind = option_detail::kind_of<T>();
  o.help = std::move(help);
  o.range = range;
  Request defaults;
  const Stored& d = field(defaults);
  if constexpr (!std::is_same_v<Stored, T>) {
    if (d) o.shown = option_detail::to_value(*d);
  } else if constexpr (std::is_same_v<T, bool>) {
    o.negated = d;  // on by default: the option turns it off
    if (d) o.shown = true;
  } else if constexpr (option_detail::kind_of<T>() == OptionKind::kText ||
                       option_detail::kind_of<T>() == OptionKind::kList) {
    if (!d.empty()) o.shown = d;
  } else {
    o.shown = option_detail::to_value(d);
  }
  o.set = [field](Request& r, const OptionValue& v, const std::string&) {
    field(r) = option_detail::from_value<T>(v);
  };
  return o;
}

// An option read in by its own function (a text parsed, a value folded into
// another field); it shows no default unless given one.
template <class Request>
CommandOption<Request> parsed_option(
    std::string name, OptionKind kind, std::string help,
    std::function<void(Request&, const OptionValue&, const std::string&)> set,
    std::optional<OptionValue> shown = {}) {
  CommandOption<Request> o;
  o.name = std::move(name);
  o.kind = kind;
  o.help = std::move(help);
  o.set = std::move(set);
  o.shown = std::move(shown);
  return o;
}

// `o` as a text of comma-separated numbers (X,Y,Z), which Python also takes as
// a list of numbers.
template <class Request>
CommandOption<Request> of_numbers(CommandOption<Request> o) {
  o.numbers = true;
  return o;
}

// The items of a list option's value: each text split at its commas.
inline std::vector<std::string> list_items(const std::vector<std::string>& given) {
  std::vector<std::string> items;
  for (const std::string& text : given) {
    if (text.empty()) continue;
    for (std::string& item : split_columns(text)) items.push_back(std::move(item));
  }
  return items;
}

// Checks a given value against the option's range and words, then reads it
// into the request; an InputError names the option as `as` (the command line's
// --flag, Python's keyword).
template <class Request>
void set_option(const CommandOption<Request>& o, Request& request, OptionValue value,
                const std::string& as) {
  if (o.range && o.kind == OptionKind::kWhole) {
    check_option(as, static_cast<double>(std::get<long long>(value)), *o.range, true);
  }
  if (o.range && o.kind == OptionKind::kNumber) check_option(as, std::get<double>(value), *o.range);
  if (!o.words.empty()) {
    const std::string& text = std::get<std::string>(value);
    if (std::find(o.words.begin(), o.words.end(), text) == o.words.end()) {
      throw InputError(
          fmt::format("{} {}: not one of {}", as, printable(text), fmt::join(o.words, ", ")));
    }
  }
  if (o.kind == OptionKind::kList) value = list_items(std::get<std::vector<std::string>>(value));
  o.set(request, value, as);
}

// The option of that keyword in a table, or null.
template <class Request>
const CommandOption<Request>* find_option(const CommandOptions<Request>& table,
                                          const std::string& name) {
  for (const CommandOption<Request>& o : table)
    if (o.name == name) return &o;
  return nullptr;
}

// How a default shows: as Python writes it (10.0, not 10; 1e-06).
inline std::string shown_text(const OptionValue& v) {
  if (const auto* b = std::get_if<bool>(&v)) return *b ? "true" : "false";
  if (const auto* n = std::get_if<long long>(&v)) return fmt::format("{}", *n);
  if (const auto* x = std::get_if<double>(&v)) {
    std::string text = fmt::format("{}", *x);
    if (text.find_first_of(".ein") == std::string::npos) text += ".0";
    return text;
  }
  if (const auto* s = std::get_if<std::string>(&v)) return *s;
  return fmt::format("{}", fmt::join(std::get<std::vector<std::string>>(v), ","));
}

// N comma-separated finite numbers (X,Y,Z), or an InputError naming the option
// as `as`.
template <std::size_t N>
std::array<double, N> comma_numbers(const std::string& text, const std::string& as) {
  const std::vector<std::string> items =
      text.empty() ? std::vector<std::string>{} : split_columns(text);
  std::array<double, N> numbers{};
  bool read = items.size() == N;
  for (std::size_t i = 0; read && i < N; ++i) {
    std::size_t used = 0;
    try {
      numbers[i] = std::stod(items[i], &used);
    } catch (const std::exception&) {
      used = 0;
    }
    read = used == items[i].size() && std::isfinite(numbers[i]);
  }
  if (!read) {
    throw InputError(
        fmt::format("{} '{}': expected {} comma-separated numbers", as, printable(text), N));
  }
  return numbers;
}

// The options every command that reads a URDF's chain takes.
template <class Request>
void add_chain_options(CommandOptions<Request>& table) {
  table.push_back(field_option<Request>(
      "tip", "Tip link of a URDF model's chain (needed unless the URDF has one leaf)",
      [](Request & r) -> auto& { return r.tip; }));
  table.push_back(field_option<Request>(
      "root", "Root link of a URDF model's chain (default: the URDF's root link)",
      [](Request & r) -> auto& { return r.root; }));
}

}  // namespace hapticcal
