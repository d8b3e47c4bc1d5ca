// commands.h — each subcommand of `palpate` registers itself on the CLI11 app.
#pragma once

#include "exit_codes.h"

#include <palpate/render.h>
#include <palpate/scene_def.h>

#include <CLI/CLI.hpp>

#include <filesystem>
#include <string>

namespace palpate::cli {
void add_run_command(CLI::App& app);
void add_info_command(CLI::App& app);
void add_precompute_command(CLI::App& app);
void add_view_command(CLI::App& app);
void add_doctor_command(CLI::App& app);
void add_report_command(CLI::App& app);
// True when standard error is a terminal: progress is shown only then.
bool stderr_is_terminal();
// --quiet,-q (errors only) and --verbose,-v (also what was loaded from where, and each stage's
// timing), which exclude each other: every command has both.
void add_output_flags(CLI::App* command, bool& quiet, bool& verbose);
// --verbose: what a scene loads and from where (its file, devices, each tissue's mesh or patch and
// predictor); `cache` is the run's --cache ("" = the default).
void print_scene_inputs(const SceneDef& scene, const std::filesystem::path& cache);
// --stereo MODE (render.h's StereoMode, by parse_stereo_mode), --eye-separation MM and
// --convergence M into `stereo`, which must outlive the parse; `what` begins --stereo's help.
void add_stereo_flags(CLI::App* command, StereoOptions& stereo, const std::string& what);
}  // namespace palpate::cli
