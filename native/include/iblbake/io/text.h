// Text from outside (file names, library messages, fuzzed headers) made safe
// to print on one line and to store in JSON.
#pragma once
#include <string>
#include <string_view>

namespace iblbake::io {

// Valid UTF-8 kept; invalid bytes, control characters and DEL written as
// \xNN, so a message stays one printable line and a manifest stays valid JSON.
std::string printable(std::string_view text);

}  // namespace iblbake::io
