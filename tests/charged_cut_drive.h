// charged_cut_drive.h — random blade paths through a charged-particle patch from bytes (issue 37,
// item 8): the body of fuzz/fuzz_charged_cut.cpp, and what test_fuzz_inputs.cpp runs its seeds
// through. Each 8-byte record is one tick: the tip's move (3 signed bytes, ±2.5 mm a tick, so some
// ticks jump past the blade's speed limit), the axis's tilt (2 bytes), the edge's length (1 byte,
// 0–25.5 mm), and a byte of events (1 a NaN pose, 2 a probe instead of a blade, 3 a negative edge,
// 4 a numerical reset, 5 healing every cut, 6 a jump back to the middle).
#pragma once

#include <palpate/charged.h>

#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <string>

namespace palpate::fuzz {

// Runs the records; a description of what broke (a non-finite force or position, cuts lost
// without clear_cuts, a link cut on one side only), or nothing.
inline std::optional<std::string> drive_charged_cut(const unsigned char* data, size_t size) {
  static const ChargedModel model = [] {
    PatchDef p;
    p.width = p.height = 0.016, p.spacing = 0.001;
    return *build_charged_patch(p, ChargedMaterialDef{});
  }();
  static ChargedState state = make_charged_state(model);
  clear_cuts(model, state);
  Vec3 tip(0, 0.002, 0);
  long cut = 0;
  for (size_t k = 0; k + 8 <= size && k < 8 * 4096; k += 8) {
    const auto b = [&](size_t i) { return static_cast<signed char>(data[k + i]); };
    tip += Vec3(b(0), b(1), b(2)) * (0.0025 / 127);
    tip = tip.cwiseMax(Vec3(-0.02, -0.01, -0.02)).cwiseMin(Vec3(0.02, 0.01, 0.02));
    ChargedHip hip;
    hip.position = tip;
    hip.axis = Vec3(b(3) / 127.0, -1, b(4) / 127.0).normalized();
    hip.blade = true, hip.sharp = false, hip.radius = 0.0005;
    hip.edge_length = data[k + 5] * 0.0001;
    const unsigned ev = data[k + 6];
    if (ev == 1) hip.position.y() = std::numeric_limits<double>::quiet_NaN();
    if (ev == 2) hip.blade = false;
    if (ev == 3) hip.edge_length = -hip.edge_length;
    if (ev == 4) reset(model, state);
    if (ev == 5) clear_cuts(model, state), cut = 0;
    if (ev == 6) tip = Vec3(0, -0.003, 0);
    const Vec3 f = step(model, state, hip, 0.001, 0);
    if (!f.allFinite()) return "tick " + std::to_string(k / 8) + ": non-finite force";
    if (state.cut_link_count < cut) return "tick " + std::to_string(k / 8) + ": cuts lost";
    cut = state.cut_link_count;
    TissueEvent events[kChargedEventCapacity];
    drain_events(state, events);
  }
  std::array<int, 6> nb{};
  for (int i = 0; i < static_cast<int>(model.size()); ++i) {
    if (!state.position(static_cast<size_t>(i)).allFinite()) return "particle " + std::to_string(i) + " not finite";
    model.neighbour_slots(i, nb);
    for (int s = 0; s < 6; ++s) {
      const int j = nb[static_cast<size_t>(s)];
      if (j < 0 || !link_cut(state, i, s)) continue;
      const int back = charged_slot_of(model, j, i);
      if (back < 0 || !link_cut(state, j, back))
        return "link " + std::to_string(i) + "-" + std::to_string(j) + " cut on one side only";
    }
  }
  return std::nullopt;
}

}  // namespace palpate::fuzz
