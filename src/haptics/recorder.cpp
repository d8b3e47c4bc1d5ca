// recorder.cpp — the recorder's writer thread: drains the ring, formats CSV rows, writes whole rows.
#include "haptics/recorder.h"

#include <palpate/safety.h>

#include <fmt/format.h>

#include <algorithm>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <fcntl.h>
#include <string_view>
#include <system_error>
#include <unistd.h>

namespace palpate {

Result<std::unique_ptr<Recorder>> Recorder::open(const std::filesystem::path& csv,
                                                 std::vector<std::string> columns,
                                                 std::vector<ColumnFormat> formats,
                                                 RecorderOptions options) {
  namespace fs = std::filesystem;
  formats.resize(columns.size(), ColumnFormat::number);
  std::unique_ptr<Recorder> r(new Recorder());
  r->final_ = csv;
  r->part_ = fs::path(csv.string() + ".part");
  r->names_ = std::move(columns);
  r->formats_ = std::move(formats);
  r->options_ = std::move(options);
  for (size_t c : r->options_.keep_columns)
    if (c >= r->names_.size())
      return Error{"recorder: kept column " + std::to_string(c) + " is past the " +
                   std::to_string(r->names_.size()) + " columns"};
  std::error_code ec;
  if (csv.has_parent_path()) fs::create_directories(csv.parent_path(), ec);
  if (ec) return Error{csv.parent_path().string() + ": cannot create directory: " + ec.message()};
  r->fd_ = ::open(r->part_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (r->fd_ < 0) return Error{r->part_.string() + ": cannot open for writing: " + std::strerror(errno)};
  std::string header;
  for (size_t c = 0; c < r->names_.size(); ++c) header += (c ? "," : "") + r->names_[c];
  header += '\n';
  if (!r->write_out(header)) return Error{r->part_.string() + ": write failed (disk full?)"};
  r->rows_ = std::make_unique<SpscRing<double>>(r->options_.capacity_rows, r->names_.size());
  r->event_ring_ = std::make_unique<SpscRing<RecorderEvent>>(1024, 1);
  if (!r->options_.keep_columns.empty()) {
    // Unlinked at once: the file is gone when the process ends, however it ends.
    const fs::path kept = r->part_.string() + ".series";
    r->kept_fd_ = ::open(kept.c_str(), O_RDWR | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
    if (r->kept_fd_ < 0) return Error{kept.string() + ": cannot open for writing: " + std::strerror(errno)};
    ::unlink(kept.c_str());
    r->kept_buf_.reserve(1 << 20);
  }
  r->writer_ = std::thread([p = r.get()] { p->writer_main(); });
  return r;
}

Recorder::~Recorder() {
  if (!closed_) (void)close();
  if (kept_fd_ >= 0) ::close(kept_fd_);
}

bool Recorder::push(std::span<const double> row) noexcept {
  if (rows_->try_push(row)) return true;
  dropped_.store(dropped_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
  return false;
}

void Recorder::push_wait(std::span<const double> row) noexcept {
  while (!rows_->try_push(row)) std::this_thread::sleep_for(std::chrono::microseconds(200));
}

bool Recorder::push_event(const RecorderEvent& e) noexcept {
  if (event_ring_->try_push({&e, 1})) return true;
  ++events_dropped_;
  return false;
}

// `buf` holds whole lines. A write that fails part-way (a full disk takes what fits, then says
// ENOSPC) is cut back to its last whole line, so the file never ends in a torn row; after a failure
// nothing more is written (no row after a gap).
bool Recorder::write_out(std::string& buf) {
  if (write_failed_.load(std::memory_order_relaxed)) {
    buf.clear();
    return false;
  }
  size_t off = 0;
  while (off < buf.size()) {
    const ssize_t n = ::write(fd_, buf.data() + off, buf.size() - off);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      write_failed_.store(true);
      const size_t nl = std::string_view(buf.data(), off).rfind('\n');
      const size_t keep = nl == std::string_view::npos ? 0 : nl + 1;
      file_bytes_ += keep;
      if (keep < off) (void)::ftruncate(fd_, static_cast<off_t>(file_bytes_));
      buf.clear();
      return false;
    }
    off += static_cast<size_t>(n);
  }
  file_bytes_ += buf.size();
  buf.clear();
  return true;
}

// Append the kept values waiting to their file; after a failure nothing more (the plots say so).
bool Recorder::write_kept() {
  if (kept_fd_ < 0 || kept_failed_) {
    kept_buf_.clear();
    return !kept_failed_;
  }
  for (size_t off = 0; off < kept_buf_.size();) {
    const ssize_t n = ::write(kept_fd_, kept_buf_.data() + off, kept_buf_.size() - off);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      kept_failed_ = true;
      break;
    }
    off += static_cast<size_t>(n);
  }
  kept_buf_.clear();
  return !kept_failed_;
}

Status Recorder::for_each_kept(const std::function<void(std::span<const double> row)>& fn) const {
  const std::string what = part_.string() + ".series (the kept columns' temporary file)";
  if (kept_fd_ < 0) return kept_rows_ == 0 ? Status{} : Status{Error{what + ": not open"}};
  if (kept_failed_) return Error{what + ": write failed (disk full?)"};
  const size_t k = options_.keep_columns.size();
  std::vector<double> block(4096 * k);
  for (std::uint64_t row = 0; row < kept_rows_;) {
    const size_t rows = static_cast<size_t>(std::min<std::uint64_t>(4096, kept_rows_ - row));
    const size_t bytes = rows * k * sizeof(double);
    size_t got = 0;
    while (got < bytes) {
      const ssize_t n = ::pread(kept_fd_, reinterpret_cast<char*>(block.data()) + got, bytes - got,
                                static_cast<off_t>(row * k * sizeof(double) + got));
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) return Error{what + ": cannot read it back: " + (n < 0 ? std::strerror(errno) : "short file")};
      got += static_cast<size_t>(n);
    }
    for (size_t r = 0; r < rows; ++r) fn(std::span<const double>(block.data() + r * k, k));
    row += rows;
  }
  return {};
}

const std::vector<double>& Recorder::kept(size_t i) const {
  if (!kept_loaded_) {
    kept_loaded_ = true;
    kept_cache_.assign(options_.keep_columns.size(), {});
    for (auto& c : kept_cache_) c.reserve(static_cast<size_t>(kept_rows_));
    const Status st = for_each_kept([&](std::span<const double> row) {
      for (size_t c = 0; c < row.size(); ++c) kept_cache_[c].push_back(row[c]);
    });
    if (!st) kept_cache_.assign(options_.keep_columns.size(), {});
  }
  return kept_cache_[i];
}

// Format every row waiting in the ring into `buf`; true when anything was drained.
bool Recorder::drain(std::string& buf) {
  bool any = false;
  char names[128];
  // At most a ring's worth per call, so a producer that never pauses still sees periodic flushes.
  size_t budget = rows_->capacity();
  for (std::span<const double> row = rows_->front(); !row.empty() && budget > 0;
       row = rows_->front(), --budget) {
    for (size_t c = 0; c < row.size(); ++c) {
      if (c) buf += ',';
      switch (formats_[c]) {
        case ColumnFormat::integer:
          fmt::format_to(std::back_inserter(buf), "{}", static_cast<long long>(row[c]));
          break;
        case ColumnFormat::safety_events:
          safety_event_names(static_cast<std::uint32_t>(row[c]), names, sizeof names);
          buf += names;
          break;
        default: fmt::format_to(std::back_inserter(buf), "{:.9g}", row[c]); break;
      }
    }
    buf += '\n';
    for (size_t c : options_.keep_columns) kept_buf_.append(reinterpret_cast<const char*>(&row[c]), sizeof(double));
    ++kept_rows_;
    rows_->pop();
    rows_written_.store(rows_written_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
    any = true;
  }
  for (std::span<const RecorderEvent> e = event_ring_->front(); !e.empty(); e = event_ring_->front()) {
    events_.push_back(e[0]);
    event_ring_->pop();
    any = true;
  }
  return any;
}

void Recorder::writer_main() {
  using Clock = std::chrono::steady_clock;
  std::string buf;
  buf.reserve(1 << 20);
  auto last_flush = Clock::now();
  const auto period = std::chrono::duration<double>(options_.flush_period);
  for (;;) {
    const bool stopping = stop_.load(std::memory_order_acquire);
    const bool any = drain(buf);
    // Whole rows only reach the file, so a run killed at any moment leaves complete lines.
    if (!buf.empty() && (stopping || Clock::now() - last_flush >= period)) {
      write_out(buf);
      write_kept();
      last_flush = Clock::now();
    }
    if (stopping) break;
    if (!any) std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
}

Status Recorder::close() {
  if (closed_) return {};
  closed_ = true;
  stop_.store(true, std::memory_order_release);
  if (writer_.joinable()) writer_.join();
  const bool synced = ::fsync(fd_) == 0;
  const bool closed_ok = ::close(fd_) == 0;
  fd_ = -1;
  if (write_failed_.load() || !synced || !closed_ok)
    return Error{part_.string() + ": write failed (disk full?); rows up to the failure are kept there"};
  if (events_dropped_ > 0) events_.push_back({0, "events_dropped", -1, 0, double(events_dropped_)});
  std::error_code ec;
  std::filesystem::rename(part_, final_, ec);
  if (ec) return Error{final_.string() + ": cannot move the finished file into place: " + ec.message()};
  return {};
}

}  // namespace palpate
