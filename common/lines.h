// Reading line-oriented files (JSON Lines and the like) with the line numbers errors must name.
#pragma once

#include <filesystem>
#include <functional>
#include <string_view>

#include "common/status.h"

namespace vigil {

// Calls `fn(text, line_no)` for every line of the file that is not blank, with a trailing CR
// removed; stops at the first error `fn` returns. A file that cannot be opened or read is an
// error naming it.
Status for_each_line(const std::filesystem::path& path, const std::function<Status(std::string_view, int)>& fn);

}  // namespace vigil
