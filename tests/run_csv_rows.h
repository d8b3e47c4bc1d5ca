// run_csv_rows.h — the tests' one reader of a haptic loop's run.csv (columns as src/haptics/loop.cpp
// writes them: t, tool_x/y/z, force_x/y/z, force_N, tick, tool_qw/qx/qy/qz, buttons, events, then
// the proxy's and the tissues' columns, kept as text in `rest`).
#pragma once

#include <palpate/core.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace palpate::test {

// One line of a CSV split at its commas; a trailing comma gives a last empty cell.
inline std::vector<std::string> csv_cells_of(const std::string& line) {
  std::vector<std::string> f;
  std::stringstream ss(line);
  for (std::string cell; std::getline(ss, cell, ',');) f.push_back(cell);
  if (!line.empty() && line.back() == ',') f.push_back("");
  return f;
}

struct RunRow {
  double t = 0;
  Vec3 tool = Vec3::Zero(), force = Vec3::Zero();
  double force_n = 0;
  long tick = 0;
  Quat q = Quat::Identity();
  std::string buttons, events;
  std::vector<std::string> rest;  // the columns after `events`
};

// Every row of a run.csv after its header; a row with fewer than 15 cells or a number that does
// not parse throws (std::out_of_range / std::invalid_argument), which fails the calling test.
inline std::vector<RunRow> read_run_rows(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::string line;
  std::getline(in, line);
  std::vector<RunRow> rows;
  while (std::getline(in, line)) {
    const std::vector<std::string> f = csv_cells_of(line);
    RunRow r;
    r.t = std::stod(f.at(0));
    r.tool = Vec3(std::stod(f.at(1)), std::stod(f.at(2)), std::stod(f.at(3)));
    r.force = Vec3(std::stod(f.at(4)), std::stod(f.at(5)), std::stod(f.at(6)));
    r.force_n = std::stod(f.at(7));
    r.tick = std::stol(f.at(8));
    r.q = Quat(std::stod(f.at(9)), std::stod(f.at(10)), std::stod(f.at(11)), std::stod(f.at(12)));
    r.buttons = f.at(13);
    r.events = f.at(14);
    r.rest.assign(f.begin() + 15, f.end());
    rows.push_back(std::move(r));
  }
  return rows;
}

}  // namespace palpate::test
