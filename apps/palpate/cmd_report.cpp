// cmd_report.cpp — `palpate report RUN_DIR... -o FILE`: several runs' attempts in one report.html,
// side by side in one table (docs/cvc.md, "The report").
#include <palpate/report.h>

#include "commands.h"
#include "exit_codes.h"

#include <fmt/core.h>

#include <memory>
#include <string>
#include <vector>

namespace palpate::cli {

namespace {

struct ReportArgs {
  std::vector<std::string> runs;
  std::string out = "report.html";
  bool quiet = false, verbose = false;
};

int report_command(const ReportArgs& a) {
  std::vector<ReportAttempt> attempts;
  for (const std::string& dir : a.runs) {
    auto attempt = read_report_attempt(dir);
    if (!attempt) {
      fmt::print(stderr, "palpate report: {}\n", attempt.error().message);
      return kExitFailed;
    }
    attempts.push_back(std::move(*attempt));
  }
  if (Status s = write_report_html(attempts, a.out); !s) {
    fmt::print(stderr, "palpate report: {}\n", s.error().message);
    return kExitFailed;
  }
  if (!a.quiet) {
    for (const ReportAttempt& t : attempts)
      fmt::print("attempt    {:<24} {:<16} {}\n", t.label, t.scene, outcome_name(t.metrics.outcome));
    fmt::print("report     {}\n", a.out);
  }
  return 0;
}

}  // namespace

void add_report_command(CLI::App& app) {
  auto args = std::make_shared<ReportArgs>();
  CLI::App* report = app.add_subcommand(
      "report", "Write one report.html comparing several runs' attempts (their output folders) in one table");
  report->add_option("runs", args->runs, "Output folders of palpate run (each with summary.json and run.csv)")
      ->required()->check(CLI::ExistingDirectory);
  report->add_option("--out,-o", args->out, "The report to write (default: report.html)");
  add_output_flags(report, args->quiet, args->verbose);
  report->callback([args] { throw CLI::RuntimeError(report_command(*args)); });
}

}  // namespace palpate::cli
