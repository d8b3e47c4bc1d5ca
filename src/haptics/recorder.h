// recorder.h — Recorder: every tick's row goes from the haptic thread through a lock-free SPSC
// ring to a writer thread that streams it to `<csv>.part`, flushed every ~100 ms, renamed at the end;
// the columns kept for the plots go, as binary doubles, to an unlinked temporary file beside it
// (read back after close(), so a run of any length holds none of them in memory).
#pragma once

#include <palpate/core.h>

#include "haptics/spsc_ring.h"

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <thread>
#include <vector>

namespace palpate {

// A tissue event on its way to the summary (kind: a static string, as in TissueEvent).
struct RecorderEvent {
  double time = 0;       // s
  const char* kind = "";
  int tissue = -1;
  double depth = 0;      // m
  double force = 0;      // N
};

// How a column is written: a number (%.9g), an integer, or a SafetyEvent mask written as names.
enum class ColumnFormat : std::uint8_t { number, integer, safety_events };

struct RecorderOptions {
  size_t capacity_rows = 8192;      // ring size: 8 s of ticks at 1 kHz before anything is dropped
  double flush_period = 0.1;        // s between writes to the file (what a killed run keeps)
  std::vector<size_t> keep_columns; // columns also kept (for plots), in a temporary file: for_each_kept()
};

class Recorder {
 public:
  // Create `<csv>.part` with the header line and start the writer thread.
  static Result<std::unique_ptr<Recorder>> open(const std::filesystem::path& csv,
                                                std::vector<std::string> columns,
                                                std::vector<ColumnFormat> formats,
                                                RecorderOptions options = {});
  ~Recorder();
  Recorder(const Recorder&) = delete;
  Recorder& operator=(const Recorder&) = delete;

  // Producer (one thread, the haptic thread). push: never blocks; a full ring drops the row and
  // counts it. push_wait: waits for room (headless runs, where nothing is lost by waiting).
  bool push(std::span<const double> row) noexcept;
  void push_wait(std::span<const double> row) noexcept;
  bool push_event(const RecorderEvent& e) noexcept;

  // Stop the writer, write what is left, fsync, rename `.part` to the final name.
  Status close();

  size_t columns() const { return names_.size(); }
  std::uint64_t dropped() const { return dropped_.load(std::memory_order_relaxed); }
  std::uint64_t rows_written() const { return rows_written_.load(std::memory_order_relaxed); }
  // After close(): the kept columns' rows in order, read back from the temporary file a block at a
  // time; `row` holds one row's kept columns (keep_columns order). An error when the file could not
  // be written (disk full) or read.
  Status for_each_kept(const std::function<void(std::span<const double> row)>& fn) const;
  std::uint64_t kept_rows() const { return kept_rows_; }
  // After close(): kept column i whole, in memory (read from the file on first use: a long run's
  // columns are large; for_each_kept streams them). Empty when the file failed.
  const std::vector<double>& kept(size_t i) const;
  const std::vector<RecorderEvent>& events() const { return events_; }
  const std::filesystem::path& part_path() const { return part_; }

 private:
  Recorder() = default;
  void writer_main();
  bool drain(std::string& buf);
  bool write_out(std::string& buf);

  std::filesystem::path final_, part_;
  std::vector<std::string> names_;
  std::vector<ColumnFormat> formats_;
  RecorderOptions options_;
  int fd_ = -1;
  std::uint64_t file_bytes_ = 0;  // bytes in the file: whole lines only (writer thread)
  std::unique_ptr<SpscRing<double>> rows_;
  std::unique_ptr<SpscRing<RecorderEvent>> event_ring_;
  std::thread writer_;
  std::atomic<bool> stop_{false};
  std::atomic<bool> write_failed_{false};
  std::atomic<std::uint64_t> dropped_{0}, rows_written_{0};
  std::uint64_t events_dropped_ = 0;  // producer-owned
  int kept_fd_ = -1;                       // the kept columns' unlinked temporary file
  std::string kept_buf_;                   // writer-owned: kept values not yet written
  std::uint64_t kept_rows_ = 0;            // writer-owned until close(): rows in kept_buf_ + file
  bool kept_failed_ = false;               // writer-owned until close(): a write failed
  bool write_kept();
  mutable std::vector<std::vector<double>> kept_cache_;  // kept(i), loaded on first use
  mutable bool kept_loaded_ = false;
  std::vector<RecorderEvent> events_;      // writer-owned until close()
  bool closed_ = false;
};

}  // namespace palpate
