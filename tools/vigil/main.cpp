// vigil: the command-line front end. Each subcommand lives in its own cmd_*.cpp.
#include <cstdio>
#include <exception>

#include "tools/vigil/commands.h"

namespace vigil::cli {

int report(const Error& e) {
  std::fprintf(stderr, "vigil: %s%s\n", e.kind == ErrorKind::kInternal ? "internal error: " : "", e.str().c_str());
  return e.kind == ErrorKind::kInternal ? 1 : 2;
}

}  // namespace vigil::cli

int main(int argc, char** argv) {
  CLI::App app{"Vigil: headless multi-robot surveillance simulator"};
  app.require_subcommand(1);
  vigil::cli::add_run_command(app);
  vigil::cli::add_validate_command(app);
  vigil::cli::add_map_command(app);
  vigil::cli::add_bench_command(app);
  vigil::cli::add_render_command(app);
  vigil::cli::add_track_command(app);
  vigil::cli::add_eval_command(app);
  vigil::cli::add_calibrate_command(app);
  vigil::cli::add_gen_command(app);
  vigil::cli::add_node_commands(app);
  vigil::cli::add_report_command(app);
  vigil::cli::add_export_mcap_command(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : 2;
  } catch (const vigil::cli::Exit& e) {
    return e.code;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "vigil: internal error: %s\n", e.what());
    return 1;
  }
  return 0;
}
