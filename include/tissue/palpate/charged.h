// palpate/charged.h — the charged-particle tissue model: patch model (constant), state (stepped),
// the HIP, builders (generated patch, patch laid on a surface mesh) and the step kernel pipeline.
#pragma once

#include <palpate/charged_def.h>
#include <palpate/core.h>
#include <palpate/mesh.h>
#include <palpate/scene_def.h>
#include <palpate/tissue.h>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace palpate {

// How a patch's particles were laid out; it decides how neighbours and nearby particles are found.
enum class ChargedLayout : std::uint8_t {
  flat,      // generated hexagonal lattice on a plane (implicit neighbours, lattice-indexed search)
  cylinder,  // the same lattice bent onto a cylinder (axis along the patch's v direction)
  sphere,    // the same lattice bent onto a sphere (u = longitude, v = latitude, times radius)
  mesh,      // particles at the vertices of a remeshed surface (explicit neighbours, cell grid)
};

// The constant part of one patch: topology, rest geometry, material and derived constants.
// Built once (build_charged_patch / build_charged_on_mesh); shared read-only by every state.
struct ChargedModel {
  ChargedMaterialDef material;
  ChargedLayout layout = ChargedLayout::flat;
  double max_separation = 0;  // m, S: the separation rule's limit (material's, or from max_strain)
  bool coulomb = false;       // material.force_model is "coulomb": the seed's contact force
  double coulomb_kqq = 0;     // N·m², k_e·hip_charge·particle_charge (coulomb)

  // Generated lattices (layout != mesh): particle index = r * cols + c, rows along v, columns
  // along u; odd rows are shifted by spacing/2 along u (hexagonal tessellation).
  int rows = 0, cols = 0;
  double spacing = 0;       // m, rest distance between lattice neighbours in (u, v)
  double row_pitch = 0;     // m, spacing · √3/2, distance between rows in v
  double u_mid = 0, v_mid = 0;  // m, lattice (u, v) of the patch centre
  Vec3 center = Vec3::Zero();   // m, patch centre (on the surface)
  Vec3 normal = Vec3::UnitY();  // unit outward normal at the centre
  Vec3 tangent_u = Vec3::UnitX(), tangent_v = Vec3::UnitZ();  // unit, (u, v, normal) right-handed
  double radius = 0;        // m, cylinder or sphere radius

  // Per particle, n = size(): rest positions and outward normals (hot data, structure of arrays).
  std::vector<float> origin_x, origin_y, origin_z;                // (n) m
  std::vector<std::int16_t> normal_x, normal_y, normal_z;         // (n) unit normal · 32767
  // Mesh patches only: (n x 6) neighbour indices, row-major, -1 = none. Lattices: empty (implicit).
  std::vector<std::int32_t> neighbours;
  // Mesh patches only: uniform cell grid over the origins; particles are sorted by cell, so cell
  // k holds particles cell_start[k] .. cell_start[k+1]-1 and has linear key cell_key[k].
  double cell_size = 0;                 // m
  Vec3 grid_min = Vec3::Zero();         // m
  std::array<std::int64_t, 3> grid_dims{0, 0, 0};
  std::vector<std::int64_t> cell_key;   // (#cells) ascending
  std::vector<std::int32_t> cell_start; // (#cells + 1)

  // Cold data, for drawing only: triangles over the particles (lattice or remeshed surface).
  std::vector<std::array<int, 3>> triangles;

  size_t size() const { return origin_x.size(); }
  Vec3 origin(size_t i) const { return Vec3(origin_x[i], origin_y[i], origin_z[i]); }
  Vec3 particle_normal(size_t i) const {
    return Vec3(normal_x[i], normal_y[i], normal_z[i]) / 32767.0;
  }
  // Neighbours of particle i into out[0..5]; returns how many (≤ 6).
  int neighbours_of(int i, std::array<int, 6>& out) const noexcept;
  // The same neighbours in fixed slots (-1 where there is none): slot k is the bit a cut link sets
  // in ChargedState::cut. Lattices: 0 (c−1), 1 (c+1), 2, 3 the row before, 4, 5 the row after
  // (columns c0, c0+1); mesh patches: the k-th entry of `neighbours`. Listing the slots that hold a
  // neighbour in order gives neighbours_of's order.
  void neighbour_slots(int i, std::array<int, 6>& out) const noexcept;
};

// A punctured hole: where the tool went through, and whether it is in the hole now.
struct ChargedHole {
  Vec3 center = Vec3::Zero();   // m, HIP position at the puncture
  Vec3 axis = Vec3::Zero();     // unit, the tool's axis at the puncture (the track's direction)
  Vec3 surface = Vec3::Zero();  // m, the rest surface's point under the HIP at the puncture
  Vec3 normal = Vec3::Zero();   // unit, the rest surface's outward normal there
  double bristle = 0;           // m, Dahl friction state in [−z0, z0] (z0 = friction_presliding)
  std::int8_t side = 1;         // +1: punctured from the outer side; −1: from inside (a vessel's lumen)
  bool in_track = false;        // the tool passes through the hole now
  bool open = false;            // slot in use
};

// What the last step did (for figures, tests and the ChainMail cost check).
struct ChargedStepStats {
  int contacts = 0;              // particles within the sphere of influence of the HIP
  int pinned = 0;                // of those, at maximum displacement
  long propagation_visits = 0;   // neighbour pairs examined by the separation rule this tick
  long propagation_moves = 0;    // particles moved by the separation rule this tick
  int propagation_overflows = 0; // ticks where the propagation hit its safety bound (never, normally)
  long candidates = 0;           // particles examined by the lattice/grid search this tick
  double max_displacement = 0;   // m, largest |position - origin| among active particles
  double indentation = 0;        // m, δ: how far the sphere of influence reaches past the rest surface
  double shaft_in_layer = 0;     // m, length of shaft inside the layer's punctured tracks
  double edge_in_layer = 0;      // m, length of a blade's edge inside the layer (its drag's length)
  double presence = 1;           // share of the layer under the tool, [0, 1]: < 1 over an open wound
  int links_cut = 0;             // neighbour links a blade cut this tick
  bool cutting = false;          // a blade pressed past cutting_force moved through the layer this tick
  long blade_jumps = 0;          // blade poses that moved too far in one tick to cut (teleports) since build
  long numeric_resets = 0;       // numerical troubles recovered since build (zero force + reset)
};

// A particle on a wound's edge (docs/models/cutting.md): its rest position moves from its origin
// by an offset that eases from `from` to `to` (m) as e^(−elasticity·(t − since)), so the edge parts
// smoothly, by elastic return, to half the wound's gap away from the cut in the surface's tangent plane.
struct ChargedWound {
  std::int32_t particle = -1;
  float away[3] = {0, 0, 0};  // sum of unit directions away from each cut that took a link of it
  float from[3] = {0, 0, 0};  // m, the offset at `since`
  float to[3] = {0, 0, 0};    // m, the offset it eases to
  double since = 0;           // s, state time the offset last changed course
};

inline constexpr int kChargedMaxHoles = 16;
// The most particles on wound edges a state holds (a cut of ~30 m at 1 mm spacing): the wound table
// is min(n, this) entries, so a million-particle patch does not carry one per particle. Edge
// particles past it are still cut, but do not part (ChargedState::wound_full counts them).
inline constexpr size_t kChargedMaxWound = size_t{1} << 16;
inline constexpr int kChargedEventCapacity = 32;

// Everything that changes while a patch is stepped. Copying it is a snapshot; reset() restores rest.
struct ChargedState {
  std::vector<float> x, y, z;         // (n) m, particle positions
  std::vector<std::uint8_t> flags;    // (n) bit 0 active, bit 1 queued, bit 2 charge reversed (hole),
                                      //   bit 3 on a wound's edge (in `wound`), bit 4 scratch (cutting)
  std::vector<std::int32_t> active;   // (n) capacity: particles away from their origin, first active_count
  std::vector<std::int32_t> queue;    // (n) ring: the separation rule's work queue (scratch)
  size_t active_count = 0;
  std::array<ChargedHole, kChargedMaxHoles> holes{};
  int next_hole = 0;                  // slot the next puncture uses (oldest reused when full)
  Vec3 force = Vec3::Zero();          // N, force of the tissue on the HIP (what the device gets)
  double time = 0;                    // s
  double contact_peak = 0;            // N, largest |force| since the HIP last came into contact
  Vec3 give = Vec3::Zero();           // N, the contact force at the last puncture, falling away
  double give_age = 0;                // s since that puncture (≥ puncture_time: given way)
  bool engaged = false;               // the tool presses the surface (contact held)
  std::int8_t side = 1;               // +1: from the outer side; −1: from inside (two_sided layers)
  ChargedStepStats stats;
  // Cuts (docs/models/cutting.md). They are the tissue's topology, not its numerical state: reset()
  // keeps them; clear_cuts() heals the patch.
  std::vector<std::uint8_t> cut;       // (n) bit k: the link to neighbour slot k is cut (symmetric)
  std::vector<ChargedWound> wound;     // (min(n, kChargedMaxWound)) the wound's edge particles, first
                                       //   wound_count, in the order cut (flags bit 3 marks them)
  std::vector<std::int32_t> wound_index;  // (power of two ≥ 2·wound.size()) open addressing, particle
                                          //   → its entry in `wound`, −1 empty
  long wound_full = 0;                 // edge particles that found the wound table full (never, normally)
  std::vector<std::int32_t> cut_scratch;  // (n) particles whose links were cut this tick (scratch)
  size_t wound_count = 0;
  long cut_link_count = 0;             // links cut so far
  Vec3 blade_heel = Vec3::Zero(), blade_tip = Vec3::Zero();  // m, a blade's edge at the last tick
  bool blade_valid = false;            // that edge is known (a blade was stepped, finite, last tick)
  bool cut_stroke = false;             // the last tick cut links (a "cut" event opens a stroke)
  Vec3 cut_bristle = Vec3::Zero();     // m, the cutting drag's Dahl state, |·| ≤ friction_presliding
  std::array<TissueEvent, kChargedEventCapacity> events{};  // ring of undrained events
  size_t event_head = 0, event_count = 0;
  long events_dropped = 0;

  Vec3 position(size_t i) const { return Vec3(x[i], y[i], z[i]); }
  bool reversed(size_t i) const { return (flags[i] & 4u) != 0; }
};

// The haptic interaction point as the kernel sees it. A needle's shaft runs from
// position - axis * shaft_length to position; a sphere probe has shaft_length 0.
struct ChargedHip {
  Vec3 position = Vec3::Zero();  // m, the HIP (sphere centre or needle tip)
  Vec3 axis = Vec3(0, -1, 0);    // unit, handle → tip
  Vec3 velocity = Vec3::Zero();  // m/s
  double shaft_length = 0;       // m
  double radius = 0;             // m, the tool's radius (sphere of influence = this + particle radius)
  bool sharp = true;             // a needle punctures at max_displacement; a blunt probe never does
  // A scalpel: its edge runs from position − axis·edge_length to position; pressed past the
  // material's cutting_force it cuts the links the edge sweeps through (docs/models/cutting.md).
  bool blade = false;
  double edge_length = 0;        // m
};

// A layer above the one being stepped, read (never written) by its step: its particles press on
// the layer below (scene order lists layers from the outside in). Both point into live objects.
struct ChargedLayer {
  const ChargedModel* model = nullptr;
  const ChargedState* state = nullptr;
};

// A generated rectangular hexagonal patch (flat, or bent onto a cylinder or sphere).
// Errors name `where` (e.g. "scene.yaml:12: tissue 'skin'") and the offending key.
Result<ChargedModel> build_charged_patch(const PatchDef& patch, const ChargedMaterialDef& material,
                                         const std::string& where = "patch");

// A patch laid on a triangulated surface: isotropic remeshing (services.remesh: CGAL) to material.mesh_spacing,
// particles at the vertices, neighbours along the edges (the six shortest where a vertex has more),
// origins on the surface, outward normals. The surface must be manifold and counter-clockwise.
Result<ChargedModel> build_charged_on_mesh(const SurfaceMesh& surface,
                                           const ChargedMaterialDef& material,
                                           const std::string& where, const TissueServices& services);

// The state at rest for `model` (allocates every scratch array the step will ever need).
ChargedState make_charged_state(const ChargedModel& model);
// Back to rest without allocating: positions at origins, no holes, no events, zero force. Cuts are
// kept (a numerical-trouble reset must not heal a wound): their edges are put at their current
// opening. clear_cuts() heals them.
void reset(const ChargedModel& model, ChargedState& state) noexcept;
// Heal every cut (links joined, wound offsets gone) and reset. Allocation-free.
void clear_cuts(const ChargedModel& model, ChargedState& state) noexcept;
// The slot of particle j among i's neighbours (ChargedModel::neighbour_slots), or −1.
int charged_slot_of(const ChargedModel& model, int i, int j) noexcept;
// Particle i's wound entry (its rest offset), or null when it is not on a wound's edge.
const ChargedWound* charged_wound_of(const ChargedState& state, int i) noexcept;
// Whether the link from particle i to its neighbour slot k is cut.
inline bool link_cut(const ChargedState& s, int i, int k) noexcept {
  return (s.cut[static_cast<size_t>(i)] >> k) & 1u;
}

// One tick of the model, dt seconds (docs/models/charged-particles.md): HIP update, relaxation
// (elasticity), repulsion, the layers `above` pressing on this one, propagation (separation rule),
// force; for a blade, the cut of what its edge swept since the last tick and the cutting drag
// (docs/models/cutting.md). Returns the force of the tissue on the HIP, N. noexcept,
// allocation-free, deterministic.
// `tissue` tags the events it emits.
Vec3 step(const ChargedModel& model, ChargedState& state, const ChargedHip& hip, double dt,
          int tissue = -1, std::span<const ChargedLayer> above = {}) noexcept;

// Move undrained events into `out` (oldest first); returns how many. Never allocates.
size_t drain_events(ChargedState& state, std::span<TissueEvent> out) noexcept;

// Bytes per particle of the model's and state's per-particle arrays (hot simulation data; the
// cold drawing triangles and the mesh's cell table are excluded and reported separately).
size_t charged_bytes_per_particle(const ChargedModel& model);

// The contact force law (N) at indentation δ (m), the depth the sphere of influence reaches past
// the rest surface: Okamura, Simone & O'Leary 2004's nonlinear spring a1·x + a2·x², its linear
// term started smoothly over the first 10 % of max_displacement so the law is C¹ at first contact:
//   Φ(δ) = a1·ψ(δ) + a2·δ²,  ψ = δ²/(2e) for δ < e, δ − e/2 beyond; e = D/10,
//   a1 = β·F_p/(D − e/2), a2 = (1 − β)·F_p/D²  (β = linear_share, F_p = puncture_force),
// so Φ(D) = F_p exactly; 0 for δ ≤ 0. Monotone, C¹ everywhere.
double charged_contact_force(const ChargedMaterialDef& mat, double indentation) noexcept;
// The snap (N, ≥ 0): the pull of a new hole's reversed charges on the tool, along the needle into
// the tissue, `age` (s) after the puncture: once the layer has given way (puncture_time τ), a C¹
// bump snap_share·F_p·16 x²(1 − x)², x = age/τ − 1, over the next τ; 0 outside (τ, 2τ).
double charged_snap_force(const ChargedMaterialDef& mat, double age) noexcept;
// The track's centring force magnitude (N) for a shaft `offset` (m) off the track's line:
// F_p·tanh(offset/R) — stiffness F_p/R at the line, saturating at the puncture force. C¹, odd.
double charged_track_force(const ChargedMaterialDef& mat, double offset, double sphere_of_influence) noexcept;
// The seed's Coulomb repulsion (N, ≥ 0) of one particle at distance r (m) from the HIP, force_model
// coulomb: kqq·(1/r_c² − 1/R²) inside the sphere of influence R (0 at its edge, so a particle
// entering it adds no step), r_c = max(r, R/10) (bounded at the centre); 0 for r ≥ R.
double charged_coulomb_force(double kqq, double r, double sphere_of_influence) noexcept;

}  // namespace palpate
