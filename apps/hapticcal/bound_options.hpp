// A command's options (jobs/command_options.hpp) on the command line: each
// becomes its --flag, with its help, its range's or words' check and the
// default it shows; the values given are kept until apply() reads them into
// the command's request (after parsing, so that a bad value is an InputError
// like any other: exit 2).
#pragma once

#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdint>
#include <deque>
#include <string>
#include <utility>
#include <vector>

#include "hapticcal/jobs/command_options.hpp"
#include "number_options.hpp"

namespace hapticcal::cli {

template <class Request>
class BoundOptions {
 public:
  BoundOptions() = default;
  BoundOptions(const BoundOptions&) = delete;  // the command line's callbacks hold `this`
  BoundOptions& operator=(const BoundOptions&) = delete;

  // Adds the table's options to `command`, in the table's order.
  void bind(CLI::App* command, const CommandOptions<Request>& table) {
    for (const CommandOption<Request>& o : table) add(command, o);
    for (const CommandOption<Request>& o : table) {
      if (o.needs.empty()) continue;
      const CommandOption<Request>* needed = find_option(table, o.needs);
      command->get_option(o.flag())->needs(command->get_option(needed->flag()));
    }
  }

  // Reads the values given into `request`, in the order given, then the flags.
  void apply(Request& request) const {
    for (const auto& [option, value] : given_) set_option(*option, request, value, option->flag());
    for (const Flag& f : flags_) {
      if (f.parsed->count() == 0) continue;
      // --no-search (true) turns the field off; --strict=false leaves it off.
      set_option(*f.option, request, OptionValue(*f.value != f.option->negated), f.option->flag());
    }
  }

 private:
  void add(CLI::App* command, const CommandOption<Request>& o) {
    const std::string flag = o.flag();
    CLI::Option* added = nullptr;
    switch (o.kind) {
      case OptionKind::kFlag: {
        // add_flag's own reading: --strict=false is false.
        bool& value = flag_values_.emplace_back(false);
        added = command->add_flag(flag, value, o.help);
        flags_.push_back({&o, added, &value});
        break;
      }
      case OptionKind::kWhole: {
        added = command->add_option_function<long long>(
            flag, [this, &o](const long long& v) { given_.emplace_back(&o, v); }, o.help);
        if (o.range) {
          const auto hi =
              std::isinf(o.range->hi) ? kNoUpperLimit : static_cast<long long>(o.range->hi);
          added->check(whole_number(static_cast<long long>(o.range->lo), hi));
        }
        break;
      }
      case OptionKind::kNumber:
        added = command->add_option_function<double>(
            flag, [this, &o](const double& v) { given_.emplace_back(&o, v); }, o.help);
        if (o.range) added->check(within(*o.range));
        break;
      case OptionKind::kText:
        added = command->add_option_function<std::string>(
            flag, [this, &o](const std::string& v) { given_.emplace_back(&o, v); }, o.help);
        if (!o.words.empty()) added->check(CLI::IsMember(o.words));
        break;
      case OptionKind::kList:
        // One value an occurrence (A,B or --fix A --fix B): a word after it is
        // the command's argument (import's RECORDING), not another item.
        added =
            command
                ->add_option_function<std::vector<std::string>>(
                    flag,
                    [this, &o](const std::vector<std::string>& v) { given_.emplace_back(&o, v); },
                    o.help)
                ->expected(1)
                ->allow_extra_args(false)
                ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
        break;
    }
    if (o.required) added->required();
    if (o.shown && o.kind != OptionKind::kFlag) added->default_str(shown_text(*o.shown));
  }

  struct Flag {
    const CommandOption<Request>* option;
    const CLI::Option* parsed;
    const bool* value;
  };
  std::vector<std::pair<const CommandOption<Request>*, OptionValue>> given_;
  std::deque<bool> flag_values_;  // add_flag's storage: stable addresses
  std::vector<Flag> flags_;
};

}  // namespace hapticcal::cli
