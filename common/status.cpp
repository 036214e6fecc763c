#include "common/status.h"

namespace vigil {

std::string Error::str() const {
  std::string out;
  if (!file.empty()) {
    out += file;
    if (line > 0) out += ":" + std::to_string(line);
    out += ": ";
  } else if (line > 0) {
    out += "line " + std::to_string(line) + ": ";
  }
  if (!key.empty()) out += key + ": ";
  out += message;
  return out;
}

Error bad_input(std::string file, int line, std::string key, std::string message) {
  return Error{ErrorKind::kBadInput, std::move(file), line, std::move(key), std::move(message)};
}

Error internal_error(std::string message) {
  return Error{ErrorKind::kInternal, "", 0, "", std::move(message)};
}

}  // namespace vigil
