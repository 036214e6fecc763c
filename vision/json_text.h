// Fixed-format text for the JSON Lines files Vigil writes (tracks, events): numbers with a fixed
// number of decimals and no negative zero, so a run's files repeat byte for byte; strings escaped
// by nlohmann::json.
#pragma once

#include <string>

namespace vigil::vision {

// `v` with `decimals` decimals ("-0.000" printed as "0.000"); "null" when not finite.
std::string fixed_number(double v, int decimals);
// `s` as a JSON string literal (invalid UTF-8 replaced).
std::string json_string(const std::string& s);

}  // namespace vigil::vision
