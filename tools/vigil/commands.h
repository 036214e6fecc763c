// The `vigil` subcommands. Each add_* registers one subcommand (and its callback) on the app;
// callbacks throw vigil::cli::Exit with the process exit code.
#pragma once

#include <CLI/CLI.hpp>

#include "world/status.h"

namespace vigil::cli {

// Thrown by a subcommand to end the program with `code` after printing its message.
struct Exit {
  int code;
};

// Prints an Error to stderr and returns its exit code (2 bad input, 1 internal).
int report(const Error& e);

void add_run_command(CLI::App& app);       // vigil run SCENARIO
void add_validate_command(CLI::App& app);  // vigil validate FILE...
void add_map_command(CLI::App& app);       // vigil map info|export
void add_bench_command(CLI::App& app);     // vigil bench sim|render|stereo
void add_bench_camera_commands(CLI::App* bench);  // vigil bench render, vigil bench stereo
void add_track_command(CLI::App& app);     // vigil track --source SPEC --pipeline planview --out DIR
void add_render_command(CLI::App& app);    // vigil render SCENARIO --camera ID --out DIR
void add_eval_command(CLI::App& app);      // vigil eval RUN_DIR | --mot-gt GT --mot-test TEST
void add_calibrate_command(CLI::App& app);
void add_gen_command(CLI::App& app);        // vigil gen FAMILY|all --seed S --count N --out DIR  // vigil calibrate stereo|floor
void add_node_commands(CLI::App& app);     // vigil camera-node, vigil server, vigil events
void add_bench_dds_commands(CLI::App* bench);  // vigil bench dds, vigil bench dds-echo
void add_bench_mcl_command(CLI::App* bench);  // vigil bench mcl
void add_bench_plan_command(CLI::App* bench);  // vigil bench plan
void add_bench_patrol_command(CLI::App* bench);  // vigil bench patrol
void add_bench_allocate_command(CLI::App* bench);  // vigil bench allocate
void add_bench_mser_command(CLI::App* bench);  // vigil bench mser
void add_bench_rate_command(CLI::App* bench);  // vigil bench camera-rate
void add_bench_video_command(CLI::App* bench);  // vigil bench video
void add_report_command(CLI::App& app);    // vigil report RUN_DIR
void add_export_mcap_command(CLI::App& app);  // vigil export-mcap RUN_DIR

}  // namespace vigil::cli
