// fuzz_charged_cut.cpp — random blade paths through a charged-particle patch (issue 37, item 8):
// crossing, re-cutting, cutting pieces off, NaN and teleporting poses, zero and negative edges,
// resets. Each 8-byte record of the input is one tick: the tip's move (3 signed bytes, ±2.5 mm a
// tick, so some ticks jump past the blade's speed limit), the axis's tilt (2 bytes), the edge's
// length (1 byte, 0–12.7 mm), and a byte of events (a NaN pose, a probe instead of a blade, a
// numerical reset, healing every cut, a jump back to the middle). A finding: a crash, a sanitizer
// report, a non-finite force or position, a cut link cut on one side only, or cuts lost without
// clear_cuts.
#include <palpate/charged.h>

#include <array>
#include <cmath>
#include <cstdlib>
#include <limits>

extern "C" int LLVMFuzzerTestOneInput(const unsigned char* data, size_t size) {
  using namespace palpate;
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
    if (!f.allFinite()) std::abort();
    if (state.cut_link_count < cut) std::abort();  // cuts only ever grow (until healed)
    cut = state.cut_link_count;
    TissueEvent events[kChargedEventCapacity];
    drain_events(state, events);
  }
  std::array<int, 6> nb{};
  for (int i = 0; i < static_cast<int>(model.size()); ++i) {
    if (!state.position(static_cast<size_t>(i)).allFinite()) std::abort();
    model.neighbour_slots(i, nb);
    for (int s = 0; s < 6; ++s) {
      const int j = nb[static_cast<size_t>(s)];
      if (j < 0 || !link_cut(state, i, s)) continue;
      const int back = charged_slot_of(model, j, i);
      if (back < 0 || !link_cut(state, j, back)) std::abort();  // cut on one side only
    }
  }
  return 0;
}
