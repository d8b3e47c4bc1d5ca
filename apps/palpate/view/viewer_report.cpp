// viewer_report.cpp — the viewer's report.html (docs/cvc.md, "The report"): the session's attempts,
// each from the loop's start (or a reset) to its stop, with the forces, the events, the 3-D view at
// the first skin puncture and at the flashback, and the live ultrasound image at the flashback.
#include "viewer_impl.h"

#include <palpate/image.h>

namespace palpate::view::detail {

namespace {

// The grey B-mode image as an RGBA image's PNG bytes ("" when there is none or it cannot be encoded).
std::string ultrasound_png(const UltrasoundImage& us) {
  if (us.width <= 0 || us.height <= 0 || us.grey.size() != size_t(us.width) * size_t(us.height)) return {};
  Image img{us.width, us.height, std::vector<std::uint8_t>(us.grey.size() * 4)};
  for (size_t i = 0; i < us.grey.size(); ++i) {
    img.rgba[4 * i] = img.rgba[4 * i + 1] = img.rgba[4 * i + 2] = us.grey[i];
    img.rgba[4 * i + 3] = 255;
  }
  auto png = encode_png(img);
  return png ? std::move(*png) : std::string();
}

}  // namespace

void Viewer::begin_attempt() {
  if (scene_.tool.kind != "needle") return;
  attempt_ = ReportAttempt{};
  attempt_.label = fmt::format("attempt {}", attempts_.size() + 1);
  attempt_.scene = scene_.name;
  attempt_.scene_file = scene_.file.string();
  attempt_.max_force = scene_.device.max_force;
  attempt_force_.clear();
  attempt_probe_force_.clear();
  seen_ = TrainingMetrics{};
  attempt_start_ = Clock::now();
  attempt_open_ = true;
}

void Viewer::record_attempt(int fb_width, int fb_height) {
  if (!attempt_open_ || !loop_) return;
  const double t = std::chrono::duration<double>(Clock::now() - attempt_start_).count();
  // The traces at no more than 50 points a second (a frame's force is the device's last).
  if (attempt_force_.empty() || t - attempt_force_.back()[0] >= 0.02) {
    attempt_force_.push_back({t, tool_force().norm()});
    if (probe_device_) attempt_probe_force_.push_back({t, probe_force().norm()});
  }
  const TrainingMetrics m = loop_->stats().metrics;
  auto frame = [&](const char* what) {
    if (fb_width <= 0 || fb_height <= 0) return;
    auto png = encode_png(Image{fb_width, fb_height, read_framebuffer(fb_width, fb_height)});
    if (png) attempt_.frames.push_back({t, std::move(*png), fmt::format("{} (t = {:.2f} s)", what, t)});
  };
  // The events are the live metrics' changes (the loop's own event list stays on its thread).
  if (m.skin_punctures > seen_.skin_punctures) {
    attempt_.events.push_back({t, "puncture", "skin", 0, tool_force().norm()});
    if (seen_.skin_punctures == 0) frame("the first skin puncture");
  }
  if (m.redirections > seen_.redirections) attempt_.events.push_back({t, "redirect", "", 0, tool_force().norm()});
  const bool venous = m.flashback && !seen_.flashback, arterial = m.arterial_flashback && !seen_.arterial_flashback;
  if (venous) attempt_.events.push_back({t, "flashback", "vein", 0, tool_force().norm()});
  if (arterial) attempt_.events.push_back({t, "arterial_flashback", "artery", 0, tool_force().norm()});
  if ((venous || arterial) && !attempt_.ultrasound) {
    frame(venous ? "the flashback" : "the arterial flashback");
    std::string png = ultrasound_png(us_image_);
    if (!png.empty())
      attempt_.ultrasound = ReportImage{t, std::move(png),
                                        fmt::format("{} at t = {:.2f} s: the live image ({})", venous ? "flashback" : "arterial flashback",
                                                    t, probe_in_plane() ? "in-plane" : "out-of-plane")};
  }
  seen_ = m;
}

void Viewer::end_attempt() {
  if (!attempt_open_) return;
  attempt_open_ = false;
  if (loop_) attempt_.metrics = loop_->stats().metrics;
  attempt_.duration = std::chrono::duration<double>(Clock::now() - attempt_start_).count();
  attempt_.force = thin_trace(attempt_force_, 4000);
  attempt_.probe_force = thin_trace(attempt_probe_force_, 4000);
  if (scene_.probe && !attempt_.ultrasound)
    attempt_.notes.push_back(attempt_.metrics.flashback || attempt_.metrics.arterial_flashback
                                 ? "No ultrasound image at the flashback: none had been drawn yet."
                                 : "No ultrasound image at the flashback: there was no flashback.");
  attempts_.push_back(std::move(attempt_));
}

void Viewer::new_attempt() {
  stop_loop();  // ends the attempt
  for (auto& t : tissues_) {
    t->reset();
    t->publish_now();
  }
  Status started = start_loop();  // begins the next
  if (!started) loop_error_ = started.error().message;
}

bool Viewer::write_report() {
  if (options_.no_report || scene_.tool.kind != "needle" || attempts_.empty()) return true;
  const std::filesystem::path file = options_.report.empty() ? scene_.output / "report.html" : options_.report;
  if (Status st = write_report_html(attempts_, file); !st) {
    fmt::print(stderr, "palpate view: report: {}\n", st.error().message);
    return false;
  }
  report_written_ = file;
  return true;
}

}  // namespace palpate::view::detail
