#include "common/lines.h"

#include <fstream>
#include <string>

namespace vigil {

Status for_each_line(const std::filesystem::path& path, const std::function<Status(std::string_view, int)>& fn) {
  std::ifstream f(path, std::ios::binary);
  if (!f) return bad_input(path.string(), 0, "", "cannot open file");
  std::string text;
  int line = 0;
  while (std::getline(f, text)) {
    ++line;
    if (!text.empty() && text.back() == '\r') text.pop_back();
    if (text.find_first_not_of(" \t") == std::string::npos) continue;
    if (Status s = fn(text, line); !s) return s;
  }
  if (f.bad()) return bad_input(path.string(), line, "", "cannot read file");
  return Status::Ok();
}

}  // namespace vigil
