// Replays the fuzz seeds and every input a fuzzer once found (fuzz/regressions/<target>/)
// through the fuzz entries (fuzz/entries.h), in the ordinary build and in the sanitized one
// (tools/test.sh --sanitize). A crash, an abort from an entry's check or a sanitizer report
// fails the test; docs/RELIABILITY.md says how the fuzzers are run.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "fuzz/entries.h"
#include "tests/test_util.h"

namespace vigil::fuzz {
namespace {
namespace fs = std::filesystem;

std::vector<uint8_t> read_bytes(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

std::vector<fs::path> files_in(const fs::path& dir, const std::string& suffix = "") {
  std::vector<fs::path> out;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return out;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.is_regular_file() && e.path().filename().string().ends_with(suffix)) out.push_back(e.path());
  std::sort(out.begin(), out.end());
  return out;
}

// The shipped files each target's fuzzer starts from (tools/fuzz.sh takes the same).
std::vector<fs::path> shipped_seeds(const std::string& target) {
  const fs::path src = VIGIL_SOURCE_DIR, shared = test::shared_data() / "maps";
  std::vector<fs::path> out;
  auto add = [&](const std::vector<fs::path>& v) { out.insert(out.end(), v.begin(), v.end()); };
  auto add_shared = [&](const std::string& suffix) {
    for (const char* m : {"DIAG_floor1", "DIAG_labs"}) add(files_in(shared / m, suffix));
  };
  if (target == "scenario") add(files_in(src / "scenarios", ".yaml"));
  if (target == "map_yaml") {
    out.push_back(src / "maps" / "dis_labs.yaml");
    add_shared(".yaml");
  }
  if (target == "stage_world") add_shared(".world");
  if (target == "floorplan") add(files_in(src / "maps", ".floorplan.yaml"));
  if (target == "patrol_graph") {
    add(files_in(src / "maps", ".graph"));
    add_shared(".graph");
  }
  return out;
}

TEST(FuzzCorpus, EveryTargetHasSeeds) {
  const fs::path corpus = fs::path(VIGIL_SOURCE_DIR) / "fuzz" / "corpus";
  ASSERT_EQ(targets().size(), 9u);
  for (const auto& t : targets()) {
    const size_t n = files_in(corpus / t.name).size() + shipped_seeds(t.name).size();
    EXPECT_GT(n, 0u) << t.name << " has no seed";
  }
  EXPECT_EQ(find_target("no such target"), nullptr);
}

TEST(FuzzCorpus, SeedsAndFoundInputsRunCleanThroughEachEntry) {
  const fs::path root = fs::path(VIGIL_SOURCE_DIR) / "fuzz";
  int inputs = 0;
  for (const auto& t : targets()) {
    std::vector<fs::path> files = files_in(root / "corpus" / t.name);
    const auto found = files_in(root / "regressions" / t.name);
    files.insert(files.end(), found.begin(), found.end());
    const auto shipped = shipped_seeds(t.name);
    files.insert(files.end(), shipped.begin(), shipped.end());
    for (const auto& f : files) {
      SCOPED_TRACE(std::string(t.name) + ": " + f.string());
      const std::vector<uint8_t> bytes = read_bytes(f);
      t.entry(bytes.data(), bytes.size());
      ++inputs;
    }
    // The empty input and a line of noise too.
    t.entry(nullptr, 0);
    const std::string noise = "\x01\xff{[: \"\n\t- ?&*!%@`";
    t.entry(reinterpret_cast<const uint8_t*>(noise.data()), noise.size());
  }
  RecordProperty("inputs", inputs);
  EXPECT_GT(inputs, 20);
}

}  // namespace
}  // namespace vigil::fuzz
