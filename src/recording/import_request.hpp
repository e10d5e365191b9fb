// What an import asks, checked before a byte of the recording is read: an
// option that would have no effect (a tracker's export option without the
// export, anything of an import with --list) is refused, never ignored; and
// what the reader is to decode (Wanted) from the request.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "hapticcal/recording/import.hpp"
#include "recording/import_topics.hpp"

namespace hapticcal::recording {

// InputError naming the option for a request with options that have no effect.
void check_request(const ImportRequest& request, const std::vector<FieldRequest>& fields);

// --frames PARENT,CHILD (InputError naming --frames otherwise).
std::pair<std::string, std::string> frames_of(const std::string& frames);

Wanted wanted_of(const ImportRequest& request, const std::vector<FieldRequest>& fields);

}  // namespace hapticcal::recording
